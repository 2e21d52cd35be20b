use std::process::ExitCode;

use speleo_scheduler::accounting::AccountingAllocator;

// Every allocation is attributed to the task running on the executive's thread.
#[global_allocator]
static ALLOC: AccountingAllocator = AccountingAllocator;

fn main() -> ExitCode {
    speleo_firmware::cli::main()
}
