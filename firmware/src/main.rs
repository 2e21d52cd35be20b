//! The `speleo` command: parses the command line and runs the mode or tool
//! it names.

use std::process::ExitCode;

use clap::Parser;
use speleo_firmware::cli::{Cli, Command, WorldCommand};
use speleo_firmware::modes;

use speleo_scheduler::accounting::AccountingAllocator;

// Every allocation is attributed to the task running on the executive's thread.
#[global_allocator]
static ALLOC: AccountingAllocator = AccountingAllocator;

fn init_logging(verbose: u8) {
    let default = match verbose {
        0 => "info",
        1 => "debug",
        _ => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .try_init();
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(cli.verbose);
    speleo_scheduler::accounting::trace_allocations_over(cli.trace_allocations_over);
    let progress = !cli.no_progress;
    let result = match cli.command {
        Command::Sim(a) => modes::sim(a, progress),
        Command::Replay(a) => modes::replay(a, progress),
        Command::Run(a) => modes::run(a, progress),
        Command::Pcap2mcap(a) => modes::pcap2mcap(a),
        Command::Decode(d) => modes::decode(d),
        Command::World(WorldCommand::Export(a)) => modes::world_export(a),
        Command::World(WorldCommand::Waypoints(a)) => modes::world_waypoints(a),
        Command::G2o(a) => modes::g2o(a),
        Command::Register(a) => modes::register(a),
        Command::Plan(a) => modes::plan(a),
        Command::Primitives(a) => modes::primitives(a),
        Command::Wcet(a) => speleo_firmware::wcet::wcet(
            a.scenario.as_deref(),
            a.config.as_ref(),
            a.report.as_ref(),
            a.calibrate.as_ref(),
            progress,
        ),
        Command::Mesh(a) => modes::mesh(a, progress),
        Command::Validate(a) => modes::validate(a),
        Command::Campaign(c) => speleo_firmware::campaign::command(c, progress),
    };
    match result {
        Ok(code) => code,
        // The reader went away (`speleo decode ... | head`): not an error.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
