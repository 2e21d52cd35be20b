//! A campaign's matrix (`campaigns/*.toml`): groups of worlds x world
//! seeds x noise seeds x configuration variants, and scenario starts,
//! expanded into numbered cases.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::success::SuccessCriteria;

/// The matrix file as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Matrix {
    pub name: String,
    /// Wall time a case may run before it is killed and counted a hang, s.
    #[serde(default = "default_timeout_s")]
    pub timeout_s: f64,
    #[serde(default, rename = "group")]
    pub groups: Vec<Group>,
    /// Configuration fragments by name (any keys of `speleo sim
    /// --config`); `baseline` is the empty one unless given.
    #[serde(default)]
    pub variants: BTreeMap<String, toml::Table>,
    #[serde(default)]
    pub scenarios: BTreeMap<String, Scenario>,
    /// Files of `[scenarios.NAME]` tables shared by several matrices,
    /// relative to the matrix's folder (`Matrix::add_scenarios`).
    #[serde(default)]
    pub scenario_files: Vec<String>,
}

/// A file of scenarios shared by several matrices, so that one name means
/// one place, limit and criterion in every campaign that pairs by it.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    #[serde(default)]
    pub scenarios: BTreeMap<String, Scenario>,
}

fn default_timeout_s() -> f64 {
    3600.0
}

/// One product of axes. Whole-cave missions name `worlds`; scenario cases
/// name `scenarios` (each scenario has its world).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Group {
    #[serde(default)]
    pub worlds: Vec<String>,
    #[serde(default)]
    pub scenarios: Vec<String>,
    #[serde(default = "one_seed")]
    pub world_seeds: Vec<u64>,
    /// The sensors' noise streams; empty: the world seed's own.
    #[serde(default)]
    pub noise_seeds: Vec<u64>,
    #[serde(default = "baseline_only")]
    pub variants: Vec<String>,
    /// Mission time limit, s (whole-cave missions; a scenario has its own).
    #[serde(default = "default_duration_s")]
    pub duration_s: f64,
}

fn one_seed() -> Vec<u64> {
    vec![1]
}

fn baseline_only() -> Vec<String> {
    vec![BASELINE.to_string()]
}

fn default_duration_s() -> f64 {
    7200.0
}

/// The variant every matrix has: the configuration's defaults.
pub const BASELINE: &str = "baseline";

/// A hard place made a short mission of its own.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub world: String,
    /// A waypoint of the world (`speleo world waypoints`) or `x,y,z,yaw`.
    pub start: String,
    /// What passing it means, in a sentence.
    #[serde(default)]
    pub description: String,
    /// Mission time limit, s.
    pub duration_s: f64,
    /// When the rover turns home, s of mission (the exploration's time
    /// limit); absent: the configuration's.
    #[serde(default)]
    pub explore_s: Option<f64>,
    /// Its success: the true track reaches this far from the start, m,
    /// and the rover ends this close to it.
    pub reach_m: f64,
    #[serde(default = "default_home_within_m")]
    pub home_within_m: f64,
}

fn default_home_within_m() -> f64 {
    SuccessCriteria::default().home_within_m
}

/// One mission of a campaign.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Case {
    pub id: usize,
    pub world: String,
    pub world_seed: u64,
    pub noise_seed: Option<u64>,
    pub variant: String,
    pub scenario: Option<String>,
    pub start: Option<String>,
    pub duration_s: f64,
    pub explore_s: Option<f64>,
    pub success: SuccessCriteria,
}

impl Case {
    /// What pairs a case with its twin in another campaign.
    pub fn key(&self) -> String {
        // Without a noise seed the sensors' noise follows the world seed,
        // so the stream is named as such and pairs with a case that names it.
        let noise = self.noise_seed.unwrap_or(self.world_seed);
        // A mesh world by its file's name: the same world planned from
        // another checkout pairs.
        let world = std::path::Path::new(&self.world)
            .file_name()
            .map_or(self.world.clone(), |n| n.to_string_lossy().into_owned());
        format!(
            "{} seed {} noise {} {}{}",
            world,
            self.world_seed,
            noise,
            self.variant,
            self.scenario
                .as_ref()
                .map_or(String::new(), |s| format!(" scenario {s}"))
        )
    }

    /// The folder of its outputs under the campaign's.
    pub fn dir_name(&self) -> String {
        format!("cases/{:04}", self.id)
    }

    /// The whole `speleo sim` configuration of the case: its variant's
    /// fragment with the case's world, seeds, time limit, start and
    /// criteria laid over it.
    pub fn config(&self, variant: &toml::Table) -> toml::Table {
        let mut cfg = variant.clone();
        let sim = sub_table(&mut cfg, "sim");
        sim.insert("world".into(), self.world.clone().into());
        sim.insert("seed".into(), int(self.world_seed));
        if let Some(n) = self.noise_seed {
            sim.insert("noise_seed".into(), int(n));
        }
        sim.insert("duration_s".into(), self.duration_s.into());
        if let Some(s) = &self.start {
            sim.insert("start".into(), s.clone().into());
        }
        let c = &self.success;
        let success = sub_table(sim, "success");
        success.insert("home_within_m".into(), c.home_within_m.into());
        success.insert("min_coverage".into(), c.min_coverage.into());
        success.insert("min_reach_m".into(), c.min_reach_m.into());
        if let Some(t) = self.explore_s {
            sub_table(&mut cfg, "exploration").insert("time_limit_s".into(), t.into());
        }
        cfg
    }
}

fn int(v: u64) -> toml::Value {
    toml::Value::Integer(v.min(i64::MAX as u64) as i64)
}

fn sub_table<'a>(t: &'a mut toml::Table, key: &str) -> &'a mut toml::Table {
    let v = t
        .entry(key.to_string())
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    if !v.is_table() {
        *v = toml::Value::Table(toml::Table::new());
    }
    match v {
        toml::Value::Table(t) => t,
        _ => unreachable!("made a table above"),
    }
}

/// Whether a case's wall-time limit is one a runner can keep, s.
pub fn timeout_ok(t: f64) -> bool {
    (1.0..=1e6).contains(&t)
}

/// The keys of `[sim]` a case sets itself; a variant that set them would
/// be silently overruled.
const CASE_KEYS: [&str; 6] = [
    "world",
    "seed",
    "noise_seed",
    "duration_s",
    "start",
    "success",
];

/// Refuses a variant that sets what the matrix's axes set.
fn check_variant(name: &str, v: &toml::Table) -> Result<(), String> {
    if let Some(sim) = v.get("sim") {
        let Some(sim) = sim.as_table() else {
            return Err(format!("variants.{name}.sim: must be a table"));
        };
        if let Some(k) = CASE_KEYS.iter().find(|k| sim.contains_key(**k)) {
            return Err(format!(
                "variants.{name}.sim.{k}: set by the matrix's groups and scenarios, not by a variant"
            ));
        }
    }
    Ok(())
}

/// What the matrix needs to know of the binary it plans for: which worlds
/// exist and what their waypoints are, and whether a configuration loads.
pub trait Catalog {
    /// The world's named waypoints, or why it is no world.
    fn waypoints(&self, world: &str, seed: u64) -> Result<Vec<String>, String>;
    /// Whether a configuration (TOML text) is one `speleo sim` accepts.
    fn check_config(&self, toml_text: &str) -> Result<(), String>;
}

impl Matrix {
    /// Parses a matrix, refusing unknown keys by name.
    pub fn parse(text: &str) -> Result<Matrix, String> {
        toml::from_str(text).map_err(|e| e.to_string().trim_end().to_string())
    }

    /// Adds the scenarios of `text`, the scenario file `file`; a name the
    /// matrix already has is refused by name.
    pub fn add_scenarios(&mut self, file: &str, text: &str) -> Result<(), String> {
        let f: ScenarioFile =
            toml::from_str(text).map_err(|e| format!("{file}: {}", e.to_string().trim_end()))?;
        for (name, sc) in f.scenarios {
            if self.scenarios.contains_key(&name) {
                return Err(format!(
                    "{file}: scenarios.{name}: already defined (by the matrix or an earlier scenario file)"
                ));
            }
            self.scenarios.insert(name, sc);
        }
        Ok(())
    }

    /// The numbered cases, every configuration checked by `catalog`.
    pub fn expand(&self, catalog: &dyn Catalog) -> Result<Vec<Case>, String> {
        if self.name.trim().is_empty() {
            return Err("name: a matrix needs a name".into());
        }
        if !timeout_ok(self.timeout_s) {
            return Err(format!(
                "timeout_s = {}: must lie within 1..=1000000 s",
                self.timeout_s
            ));
        }
        for (name, v) in &self.variants {
            check_variant(name, v)?;
        }
        if self.groups.is_empty() {
            return Err("group: the matrix has no [[group]], so no cases".into());
        }
        let mut cases = Vec::new();
        let mut waypoints: BTreeMap<(String, u64), Vec<String>> = BTreeMap::new();
        for (g, group) in self.groups.iter().enumerate() {
            let at = |key: &str| format!("group[{g}].{key}");
            let empty = |key: &str, n: usize| {
                if n == 0 {
                    Err(format!("{}: is empty, so the group has no cases", at(key)))
                } else {
                    Ok(())
                }
            };
            match (group.worlds.is_empty(), group.scenarios.is_empty()) {
                (true, true) => {
                    return Err(format!(
                        "{}: a group names worlds or scenarios; this one names neither",
                        at("worlds")
                    ))
                }
                (false, false) => {
                    return Err(format!(
                        "{}: a group names worlds or scenarios, not both",
                        at("scenarios")
                    ))
                }
                _ => {}
            }
            empty("world_seeds", group.world_seeds.len())?;
            empty("variants", group.variants.len())?;
            if !(group.duration_s.is_finite() && group.duration_s > 0.0) {
                return Err(format!(
                    "{} = {}: must be positive",
                    at("duration_s"),
                    group.duration_s
                ));
            }
            for v in &group.variants {
                if v != BASELINE && !self.variants.contains_key(v) {
                    return Err(format!(
                        "{}: unknown variant \"{v}\" (the matrix's [variants]: {})",
                        at("variants"),
                        self.variant_names().join(", ")
                    ));
                }
            }
            let noise: Vec<Option<u64>> = if group.noise_seeds.is_empty() {
                vec![None]
            } else {
                group.noise_seeds.iter().copied().map(Some).collect()
            };
            // A start of each kind: the world's own, or a scenario's.
            let mut starts: Vec<(String, Option<&String>)> = Vec::new();
            for w in &group.worlds {
                starts.push((w.clone(), None));
            }
            for s in &group.scenarios {
                let Some(sc) = self.scenarios.get(s) else {
                    return Err(format!(
                        "{}: unknown scenario \"{s}\" (the matrix's [scenarios]: {})",
                        at("scenarios"),
                        self.scenarios
                            .keys()
                            .cloned()
                            .collect::<Vec<_>>()
                            .join(", ")
                    ));
                };
                starts.push((sc.world.clone(), Some(s)));
            }
            for (world, scenario) in &starts {
                for &seed in &group.world_seeds {
                    let names = match waypoints.get(&(world.clone(), seed)) {
                        Some(n) => n.clone(),
                        None => {
                            let n = catalog.waypoints(world, seed).map_err(|e| {
                                let key = match scenario {
                                    Some(s) => format!("scenarios.{s}.world"),
                                    None => at("worlds"),
                                };
                                format!("{key}: unknown world \"{world}\": {e}")
                            })?;
                            waypoints.insert((world.clone(), seed), n.clone());
                            n
                        }
                    };
                    for &noise_seed in &noise {
                        for variant in &group.variants {
                            let case = match scenario {
                                None => Case {
                                    id: cases.len(),
                                    world: world.clone(),
                                    world_seed: seed,
                                    noise_seed,
                                    variant: variant.clone(),
                                    scenario: None,
                                    start: None,
                                    duration_s: group.duration_s,
                                    explore_s: None,
                                    success: SuccessCriteria::default(),
                                },
                                Some(name) => {
                                    let sc = &self.scenarios[*name];
                                    self.check_scenario(name, sc, &names)?;
                                    Case {
                                        id: cases.len(),
                                        world: world.clone(),
                                        world_seed: seed,
                                        noise_seed,
                                        variant: variant.clone(),
                                        scenario: Some((*name).clone()),
                                        start: Some(sc.start.clone()),
                                        duration_s: sc.duration_s,
                                        explore_s: sc.explore_s,
                                        success: SuccessCriteria {
                                            home_within_m: sc.home_within_m,
                                            min_coverage: 0.0,
                                            min_reach_m: sc.reach_m,
                                        },
                                    }
                                }
                            };
                            cases.push(case);
                        }
                    }
                }
            }
        }
        // Each configuration is checked once, as the binary will load it.
        let mut checked = std::collections::BTreeSet::new();
        for c in &cases {
            let text = toml::to_string(&c.config(self.variant(&c.variant)))
                .map_err(|e| format!("case {}: {e}", c.id))?;
            if checked.insert(text.clone()) {
                catalog.check_config(&text).map_err(|e| {
                    format!("variants.{}: case {} ({}): {e}", c.variant, c.id, c.key())
                })?;
            }
        }
        let mut keys = std::collections::BTreeMap::new();
        for c in &cases {
            if let Some(first) = keys.insert(c.key(), c.id) {
                return Err(format!(
                    "group: cases {first} and {} are the same mission ({})",
                    c.id,
                    c.key()
                ));
            }
        }
        Ok(cases)
    }

    /// The fragment of a variant (`baseline`: empty unless the matrix
    /// gives one).
    pub fn variant(&self, name: &str) -> &toml::Table {
        static EMPTY: std::sync::OnceLock<toml::Table> = std::sync::OnceLock::new();
        self.variants
            .get(name)
            .unwrap_or_else(|| EMPTY.get_or_init(toml::Table::new))
    }

    fn variant_names(&self) -> Vec<String> {
        let mut v: Vec<String> = self.variants.keys().cloned().collect();
        if !v.iter().any(|n| n == BASELINE) {
            v.insert(0, BASELINE.into());
        }
        v
    }

    fn check_scenario(
        &self,
        name: &str,
        sc: &Scenario,
        waypoints: &[String],
    ) -> Result<(), String> {
        let at = |key: &str| format!("scenarios.{name}.{key}");
        let is_pose = sc.start.split(',').count() == 4
            && sc
                .start
                .split(',')
                .all(|t| t.trim().parse::<f64>().is_ok_and(f64::is_finite));
        if !is_pose && !waypoints.contains(&sc.start) {
            return Err(format!(
                "{}: \"{}\" is neither x,y,z,yaw nor a waypoint of {} ({})",
                at("start"),
                sc.start,
                sc.world,
                waypoints.join(", ")
            ));
        }
        let positive = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{} = {v}: must be positive", at(key)))
            }
        };
        positive("duration_s", sc.duration_s)?;
        if let Some(e) = sc.explore_s {
            positive("explore_s", e)?;
        }
        positive("reach_m", sc.reach_m)?;
        if !(sc.home_within_m.is_finite() && sc.home_within_m >= 0.0) {
            return Err(format!(
                "{} = {}: must be zero or more",
                at("home_within_m"),
                sc.home_within_m
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a broken fixture fails the test where it breaks
mod tests {
    use super::*;

    #[test]
    fn scenarios_from_a_shared_file_are_added_and_a_second_definition_refused() {
        let mut m = Matrix::parse(
            "name = \"t\"\nscenario_files = [\"s.toml\"]\n[[group]]\nscenarios = [\"descent\"]\n",
        )
        .unwrap();
        assert_eq!(m.scenario_files, ["s.toml"]);
        let file = "[scenarios.descent]\nworld = \"tube\"\nstart = \"m50\"\nduration_s = 10\nreach_m = 5\n";
        m.add_scenarios("s.toml", file).unwrap();
        assert_eq!(m.scenarios["descent"].start, "m50");
        let e = m.add_scenarios("again.toml", file).unwrap_err();
        assert!(
            e.contains("again.toml") && e.contains("scenarios.descent"),
            "{e}"
        );
        let e = m
            .add_scenarios("bad.toml", "[scenarios.x]\nworld = \"tube\"\nbogus = 1\n")
            .unwrap_err();
        assert!(e.contains("bad.toml") && e.contains("bogus"), "{e}");
    }

    /// Two worlds with a few waypoints; a configuration is refused when it
    /// holds the word `bogus`.
    struct TwoWorlds;

    impl Catalog for TwoWorlds {
        fn waypoints(&self, world: &str, _seed: u64) -> Result<Vec<String>, String> {
            match world {
                "flat" => Ok(vec!["start".into()]),
                "tube" => Ok(vec!["start".into(), "m50".into()]),
                _ => Err("no such world".into()),
            }
        }
        fn check_config(&self, toml_text: &str) -> Result<(), String> {
            if toml_text.contains("bogus") {
                Err("unknown field `bogus`".into())
            } else {
                Ok(())
            }
        }
    }

    const MATRIX: &str = r#"
name = "t"
[[group]]
worlds = ["flat", "tube"]
world_seeds = [1, 2]
noise_seeds = [1, 2, 3]
variants = ["baseline", "careful"]
duration_s = 60

[[group]]
scenarios = ["descent"]
noise_seeds = [4, 5]

[variants.careful]
planner = { max_bump_m = 0.06 }

[scenarios.descent]
world = "tube"
start = "m50"
duration_s = 300
explore_s = 200
reach_m = 15
"#;

    #[test]
    fn a_matrix_expands_into_the_product_of_its_axes_numbered_in_order() {
        let m = Matrix::parse(MATRIX).unwrap();
        let cases = m.expand(&TwoWorlds).unwrap();
        assert_eq!(cases.len(), 2 * 2 * 3 * 2 + 2);
        assert!(cases.iter().enumerate().all(|(i, c)| c.id == i));
        let sc = &cases[24];
        assert_eq!(sc.scenario.as_deref(), Some("descent"));
        assert_eq!(sc.start.as_deref(), Some("m50"));
        assert_eq!(sc.success.min_coverage, 0.0);
        assert_eq!(sc.success.min_reach_m, 15.0);
        let cfg = sc.config(m.variant(&sc.variant));
        assert_eq!(cfg["sim"]["start"].as_str(), Some("m50"));
        assert_eq!(cfg["sim"]["noise_seed"].as_integer(), Some(4));
        assert_eq!(cfg["exploration"]["time_limit_s"].as_float(), Some(200.0));
        let careful = cases.iter().find(|c| c.variant == "careful").unwrap();
        let cfg = careful.config(m.variant("careful"));
        assert_eq!(cfg["planner"]["max_bump_m"].as_float(), Some(0.06));
        assert_eq!(cfg["sim"]["duration_s"].as_float(), Some(60.0));
        // Every case is its own mission.
        let keys: std::collections::BTreeSet<String> = cases.iter().map(Case::key).collect();
        assert_eq!(keys.len(), cases.len());
    }

    fn refused(text: &str) -> String {
        match Matrix::parse(text) {
            Err(e) => e,
            Ok(m) => m.expand(&TwoWorlds).expect_err("refused"),
        }
    }

    #[test]
    fn bad_matrices_are_refused_with_the_key_named() {
        let e = refused("name = \"t\"\nwrold = 1\n");
        assert!(e.contains("wrold"), "{e}");
        let e = refused("name = \"t\"\n[[group]]\nworlds = [\"flat\"]\nseeds = [1]\n");
        assert!(e.contains("seeds"), "{e}");
        let e = refused("name = \"t\"\n");
        assert!(e.contains("group"), "{e}");
        let e = refused("name = \"t\"\n[[group]]\nworlds = [\"moon\"]\n");
        assert!(e.contains("group[0].worlds") && e.contains("moon"), "{e}");
        let e = refused("name = \"t\"\n[[group]]\nworlds = []\n");
        assert!(e.contains("group[0].worlds"), "{e}");
        let e = refused("name = \"t\"\n[[group]]\nworlds = [\"flat\"]\nworld_seeds = []\n");
        assert!(e.contains("group[0].world_seeds"), "{e}");
        let e = refused("name = \"t\"\n[[group]]\nworlds = [\"flat\"]\nvariants = [\"fast\"]\n");
        assert!(e.contains("group[0].variants") && e.contains("fast"), "{e}");
        let e = refused(
            "name = \"t\"\n[[group]]\nworlds = [\"flat\"]\nvariants = [\"v\"]\n[variants.v]\nbogus = 1\n",
        );
        assert!(e.contains("variants.v") && e.contains("bogus"), "{e}");
        let e = refused("name = \"t\"\n[[group]]\nscenarios = [\"s\"]\n");
        assert!(
            e.contains("group[0].scenarios") && e.contains("\"s\""),
            "{e}"
        );
        let e = refused(
            "name = \"t\"\n[[group]]\nscenarios = [\"s\"]\n[scenarios.s]\nworld = \"tube\"\nstart = \"m90\"\nduration_s = 10\nreach_m = 5\n",
        );
        assert!(e.contains("scenarios.s.start") && e.contains("m90"), "{e}");
        let e = refused(
            "name = \"t\"\n[[group]]\nscenarios = [\"s\"]\n[scenarios.s]\nworld = \"tube\"\nstart = \"m50\"\nduration_s = 10\nreach_m = 5\nreach = 3\n",
        );
        assert!(e.contains("reach"), "{e}");
        let e = refused("name = \"t\"\n[[group]]\nworlds = [\"flat\", \"flat\"]\n");
        assert!(e.contains("same mission"), "{e}");
        let e = refused("name = \"t\"\ntimeout_s = 0\n[[group]]\nworlds = [\"flat\"]\n");
        assert!(e.contains("timeout_s"), "{e}");
        let e = refused("name = \"t\"\ntimeout_s = 1e20\n[[group]]\nworlds = [\"flat\"]\n");
        assert!(e.contains("timeout_s"), "{e}");
        let e = refused(
            "name = \"t\"\n[[group]]\nworlds = [\"flat\"]\nvariants = [\"v\"]\n[variants.v]\nsim = { duration_s = 5 }\n",
        );
        assert!(e.contains("variants.v.sim.duration_s"), "{e}");
        let e = refused(
            "name = \"t\"\n[[group]]\nscenarios = [\"s\"]\n[scenarios.s]\nworld = \"tube\"\nstart = \"1,2,nan,0\"\nduration_s = 10\nreach_m = 5\n",
        );
        assert!(e.contains("scenarios.s.start"), "{e}");
        let e = refused(
            "name = \"t\"\n[[group]]\nscenarios = [\"s\"]\n[scenarios.s]\nworld = \"moon\"\nstart = \"start\"\nduration_s = 10\nreach_m = 5\n",
        );
        assert!(e.contains("scenarios.s.world") && e.contains("moon"), "{e}");
    }

    #[test]
    fn a_pose_start_needs_no_waypoint() {
        let m = Matrix::parse(
            "name = \"t\"\n[[group]]\nscenarios = [\"s\"]\n[scenarios.s]\nworld = \"flat\"\nstart = \"1,2,0,90\"\nduration_s = 10\nreach_m = 5\n",
        )
        .unwrap();
        let cases = m.expand(&TwoWorlds).unwrap();
        assert_eq!(cases[0].start.as_deref(), Some("1,2,0,90"));
        assert_eq!(cases[0].noise_seed, None);
    }
}
