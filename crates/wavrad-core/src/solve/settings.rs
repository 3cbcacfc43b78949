//! The user-facing settings of a solve, described once
//! ([`crate::setting`]): the CLI's solve options, the keyword arguments of
//! Python's `wavrad.solve` and the `settings` of the statistics JSON.

use super::{SolveSettings, Solver};
use crate::refine::cluster_links::MAX_CLUSTER_RATIO;
use crate::refine::oracle::Oracle;
use crate::setting::{Choice, Described, Domain, Group, Setting, Value};
use crate::Result;

/// Largest element level any setting may ask for: 4^16 elements per surface.
pub const MAX_LEVEL: u32 = 16;

/// Largest time limit accepted, in seconds (a year).
const MAX_TIME_LIMIT: f64 = 3.2e7;

/// Largest memory limit accepted, in GiB.
const MAX_MEMORY_GIB: f64 = 1e6;

/// Largest oracle threshold accepted; above about 1 nothing refines.
const MAX_THRESHOLD: f64 = 1e3;

impl Described for SolveSettings {
    const SETTINGS: &'static [Setting] = &[
        Setting {
            name: "oracle",
            group: Group::Solve,
            domain: Domain::Choice(Oracle::NAMES),
            default: "kernel",
            help: "Which test decides that a link is fine enough: `kernel` (the paper's: Haar \
                   details of the kernel alone), `power` (kernel variation × radiance carried, \
                   Hanrahan et al. 1991) or `importance` (power × the receiver's importance for \
                   the scene's sensor, Smits et al. 1992). The last two run a refine–solve loop.",
        },
        Setting {
            name: "threshold",
            group: Group::Solve,
            domain: Domain::Real {
                min: 0.0,
                max: MAX_THRESHOLD,
            },
            default: "1e-3; 2e-4 with the power and importance oracles",
            help: "Oracle threshold of two-point links. Kernel oracle: on the kernel's Haar \
                   detail coefficients in the paper's orthonormal normalisation (the paper uses \
                   1e-4). Weighted oracles: on the estimated error of a receiver's radiance \
                   relative to the brightest emission.",
        },
        Setting {
            name: "max_level",
            group: Group::Solve,
            domain: Domain::Count {
                min: 0,
                max: MAX_LEVEL,
            },
            default: "5",
            help:
                "Deepest subdivision level of the largest surface's elements (the paper uses 8); \
                   smaller surfaces stop where their elements are as small as its.",
        },
        Setting {
            name: "three_point_threshold",
            group: Group::Solve,
            domain: Domain::Real {
                min: 0.0,
                max: MAX_THRESHOLD,
            },
            default: "1e-5; 2e-4 with the power and importance oracles",
            help: "Oracle threshold of three-point (glossy) links.",
        },
        Setting {
            name: "three_point_max_level",
            group: Group::Solve,
            domain: Domain::Count {
                min: 0,
                max: MAX_LEVEL,
            },
            default: "2",
            help: "Deepest subdivision level of the elements of three-point (glossy) links.",
        },
        Setting {
            name: "three_point_receiver_levels",
            group: Group::Solve,
            domain: Domain::Count {
                min: 0,
                max: MAX_LEVEL,
            },
            default: "3",
            help: "Levels the receiving element of a three-point link may go below \
                   three_point_max_level, for light straight from an emitter where the glossy \
                   surface's lobe is sharp and narrower than the element: sharper highlights on \
                   diffuse receivers for no extra ray queries.",
        },
        Setting {
            name: "cluster_ratio",
            group: Group::Solve,
            domain: Domain::Real {
                min: 0.0,
                max: MAX_CLUSTER_RATIO,
            },
            default: "0.25",
            help: "Largest (size of both ends)/distance of a link between clusters of surfaces: \
                   groups of surfaces this small against their distance exchange light as \
                   wholes (0: every pair of surfaces is linked, as in the paper).",
        },
        Setting {
            name: "refine_passes",
            group: Group::Solve,
            domain: Domain::Count { min: 1, max: 64 },
            default: "4",
            help: "Most projections of the refine–solve loop of the power and importance oracles \
                   (the first counts).",
        },
        Setting {
            name: "tolerance",
            group: Group::Solve,
            domain: Domain::Real {
                min: f64::MIN_POSITIVE,
                max: 1.0,
            },
            default: "1e-5",
            help: "Gauss–Seidel stops when the power all surfaces send changes in a sweep by at \
                   most this fraction of itself.",
        },
        Setting {
            name: "max_iterations",
            group: Group::Solve,
            domain: Domain::Count {
                min: 1,
                max: 100_000,
            },
            default: "200",
            help: "Most Gauss–Seidel sweeps.",
        },
        Setting {
            name: "time_limit",
            group: Group::Solve,
            domain: Domain::Real {
                min: 0.0,
                max: MAX_TIME_LIMIT,
            },
            default: "0",
            help: "Seconds the solve may take (0: no limit). When they are spent, the surface \
                   pairs left are linked without refinement, Gauss–Seidel stops after its \
                   sweep, and the solution is finished from what was done, with a warning.",
        },
        Setting {
            name: "max_memory",
            group: Group::Solve,
            domain: Domain::Real {
                min: 0.0,
                max: MAX_MEMORY_GIB,
            },
            default: "0",
            help: "GiB of memory the process may hold while solving (0: 80 % of the machine's). \
                   When it is reached, refinement and the solve stop as with time_limit.",
        },
    ];

    fn get(&self, name: &str) -> Option<Value> {
        Some(match name {
            "oracle" => Value::Choice(self.oracle.name()),
            "threshold" => Value::Real(self.refine.threshold),
            "max_level" => Value::Count(self.refine.max_level),
            "three_point_threshold" => Value::Real(self.three_point_threshold),
            "three_point_max_level" => Value::Count(self.three_point_max_level),
            "three_point_receiver_levels" => Value::Count(self.three_point_receiver_levels),
            "cluster_ratio" => Value::Real(self.cluster_ratio),
            "refine_passes" => Value::Count(self.max_refine_passes),
            "tolerance" => Value::Real(self.tolerance),
            "max_iterations" => Value::Count(self.max_iterations),
            "time_limit" => Value::Real(self.time_limit),
            "max_memory" => Value::Real(self.max_memory),
            _ => return None,
        })
    }

    fn set_checked(&mut self, name: &str, value: Value) -> Result<()> {
        match (name, value) {
            ("oracle", Value::Choice(name)) => {
                self.oracle = name.parse().expect("checked against the oracles' names")
            }
            ("threshold", Value::Real(t)) => self.refine.threshold = t,
            ("max_level", Value::Count(j)) => self.refine.max_level = j,
            ("three_point_threshold", Value::Real(t)) => self.three_point_threshold = t,
            ("three_point_max_level", Value::Count(j)) => self.three_point_max_level = j,
            ("three_point_receiver_levels", Value::Count(j)) => {
                self.three_point_receiver_levels = j
            }
            ("cluster_ratio", Value::Real(r)) => self.cluster_ratio = r,
            ("refine_passes", Value::Count(n)) => self.max_refine_passes = n,
            ("tolerance", Value::Real(t)) => self.tolerance = t,
            ("max_iterations", Value::Count(n)) => self.max_iterations = n,
            ("time_limit", Value::Real(t)) => self.time_limit = t,
            ("max_memory", Value::Real(m)) => self.max_memory = m,
            _ => unreachable!("{name} = {value:?} was checked against SETTINGS"),
        }
        Ok(())
    }
}

impl SolveSettings {
    /// The settings users gave by name: the defaults of the oracle among
    /// them (its thresholds differ), then every other one, each checked
    /// against its description.
    pub fn from_values(given: &[(&str, Value)]) -> Result<SolveSettings> {
        let mut settings = SolveSettings::default();
        for &(name, value) in given.iter().filter(|(name, _)| *name == "oracle") {
            settings.set(name, value)?;
            settings = SolveSettings::for_oracle(settings.oracle);
        }
        for &(name, value) in given.iter().filter(|(name, _)| *name != "oracle") {
            settings.set(name, value)?;
        }
        settings.validate()?;
        Ok(settings)
    }
}

impl Choice for Solver {
    const KIND: &'static str = "solver";
    const ALL: &'static [Self] = &[Solver::Gather, Solver::Shoot];
    const NAMES: &'static [&'static str] = &["gather", "shoot"];
}
crate::named_choice!(Solver);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_setting_reads_back_what_was_written() {
        crate::setting::tests::every_setting_reads_back::<SolveSettings>();
    }

    #[test]
    fn the_oracle_given_sets_the_thresholds_defaults_whatever_the_order() {
        let level = ("max_level", Value::Count(6));
        let power = ("oracle", Value::Choice("power"));
        let mut expected = SolveSettings::for_oracle(Oracle::Power);
        expected.refine.max_level = 6;
        assert_eq!(
            SolveSettings::from_values(&[level, power]).unwrap(),
            expected
        );
        assert_eq!(
            SolveSettings::from_values(&[power, level]).unwrap(),
            expected
        );
        assert!(SolveSettings::from_values(&[("oracle", Value::Choice("psychic"))]).is_err());
        assert!(SolveSettings::from_values(&[("colour", Value::Flag(true))]).is_err());
    }

    #[test]
    fn described_ranges_agree_with_validate() {
        let mut settings = SolveSettings::default();
        for level in 0..=MAX_LEVEL {
            settings.set("max_level", Value::Count(level)).unwrap();
            settings.validate().unwrap();
        }
        assert!(settings
            .apply("max_level", &(MAX_LEVEL + 1).to_string())
            .is_err());
        assert!(settings.apply("tolerance", "0").is_err());
    }
}
