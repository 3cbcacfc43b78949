//! One description of every user-facing setting: its name, group, range,
//! default and help. The CLI makes its options from it, the Python API its
//! keyword arguments, and the statistics JSON its `settings` object, so the
//! three cannot drift apart.
//!
//! ```
//! use wavrad_core::setting::{Described, Value};
//! use wavrad_core::solve::SolveSettings;
//!
//! let mut settings = SolveSettings::default();
//! settings.apply("max_level", "6").unwrap();
//! assert_eq!(settings.get("max_level"), Some(Value::Count(6)));
//! assert!(settings.apply("max_level", "99").is_err());
//! ```

use crate::{Error, Result};
use std::fmt;

/// Where a setting belongs (a heading of `--help`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group {
    /// How the radiance system is projected and solved.
    Solve,
    /// How a view is rendered from a solution.
    Render,
}

impl Group {
    /// The heading the group's options appear under.
    pub fn heading(self) -> &'static str {
        match self {
            Group::Solve => "Solve options",
            Group::Render => "Render options",
        }
    }
}

/// The values a setting may take.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Domain {
    /// A finite real number in `[min, max]`.
    Real {
        /// Smallest accepted value.
        min: f64,
        /// Largest accepted value.
        max: f64,
    },
    /// A whole number in `[min, max]`.
    Count {
        /// Smallest accepted value.
        min: u32,
        /// Largest accepted value.
        max: u32,
    },
    /// On or off.
    Flag,
    /// One of these names.
    Choice(&'static [&'static str]),
}

/// A setting's value (in JSON: a number, a boolean or a name).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum Value {
    /// Of a [`Domain::Real`] setting.
    Real(f64),
    /// Of a [`Domain::Count`] setting.
    Count(u32),
    /// Of a [`Domain::Flag`] setting.
    Flag(bool),
    /// Of a [`Domain::Choice`] setting: one of its names.
    Choice(&'static str),
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Real(x) => write!(f, "{x:e}"),
            Value::Count(n) => write!(f, "{n}"),
            Value::Flag(b) => write!(f, "{b}"),
            Value::Choice(name) => f.write_str(name),
        }
    }
}

/// One user-facing setting.
#[derive(Debug, Clone, Copy)]
pub struct Setting {
    /// Its name: the Python keyword and the JSON key; the CLI flag is the
    /// same with dashes (`max_level` → `--max-level`).
    pub name: &'static str,
    /// Where it belongs.
    pub group: Group,
    /// The values it takes.
    pub domain: Domain,
    /// Its default, as users read it (some depend on another setting or on
    /// the scene; the text says how).
    pub default: &'static str,
    /// What it does, in a sentence or two.
    pub help: &'static str,
}

impl Setting {
    /// The CLI flag, `--` and the name with dashes.
    pub fn flag(&self) -> String {
        format!("--{}", self.name.replace('_', "-"))
    }

    /// The value `text` (a command line's) means, if it is in the domain.
    pub fn parse(&self, text: &str) -> Result<Value> {
        let bad = |why: &str| self.invalid(format!("{text:?} {why}"));
        let value = match self.domain {
            Domain::Real { .. } => {
                Value::Real(text.trim().parse().map_err(|_| bad("is not a number"))?)
            }
            Domain::Count { .. } => Value::Count(
                text.trim()
                    .parse()
                    .map_err(|_| bad("is not a whole number ≥ 0"))?,
            ),
            Domain::Flag => Value::Flag(
                text.trim()
                    .parse()
                    .map_err(|_| bad("is not true or false"))?,
            ),
            Domain::Choice(names) => Value::Choice(
                names
                    .iter()
                    .find(|n| **n == text)
                    .ok_or_else(|| bad(&format!("is not one of: {}", names.join(", "))))?,
            ),
        };
        self.check(value)
    }

    /// `value` itself, if it is of the domain's kind and within its range.
    pub fn check(&self, value: Value) -> Result<Value> {
        match (self.domain, value) {
            (Domain::Real { min, max }, Value::Real(x))
                if !(x.is_finite() && min <= x && x <= max) =>
            {
                Err(self.invalid(format!(
                    "must be a finite number in [{min:e}, {max:e}], got {x}"
                )))
            }
            (Domain::Count { min, max }, Value::Count(n)) if !(min <= n && n <= max) => {
                Err(self.invalid(format!("must be in {min}..={max}, got {n}")))
            }
            (Domain::Choice(names), Value::Choice(name)) if !names.contains(&name) => Err(self
                .invalid(format!(
                    "must be one of: {}, got {name:?}",
                    names.join(", ")
                ))),
            (Domain::Real { .. }, Value::Real(_))
            | (Domain::Count { .. }, Value::Count(_))
            | (Domain::Flag, Value::Flag(_))
            | (Domain::Choice(_), Value::Choice(_)) => Ok(value),
            _ => Err(self.invalid(format!("got a value of the wrong kind ({value:?})"))),
        }
    }

    fn invalid(&self, why: String) -> Error {
        Error::InvalidSetting(format!("{}: {why}", self.name))
    }
}

/// A settings struct whose user-facing fields a table of [`Setting`]s
/// describes; `get` and `set` read and write them by name.
pub trait Described {
    /// The table: every user-facing setting of the struct.
    const SETTINGS: &'static [Setting];

    /// The value of setting `name` (`None` if the table has no such name).
    fn get(&self, name: &str) -> Option<Value>;

    /// Write a value that [`Setting::check`] accepted; an error where it
    /// does not go with the other settings.
    fn set_checked(&mut self, name: &str, value: Value) -> Result<()>;

    /// The setting called `name`.
    fn setting(name: &str) -> Result<&'static Setting> {
        Self::SETTINGS
            .iter()
            .find(|s| s.name == name)
            .ok_or_else(|| Error::InvalidSetting(format!("there is no setting {name:?}")))
    }

    /// Set `name` to `value`, checked against its domain.
    fn set(&mut self, name: &str, value: Value) -> Result<()> {
        let value = Self::setting(name)?.check(value)?;
        self.set_checked(name, value)
    }

    /// Set `name` from a command line's `text`.
    fn apply(&mut self, name: &str, text: &str) -> Result<()> {
        let value = Self::setting(name)?.parse(text)?;
        self.set_checked(name, value)
    }

    /// Every setting's current value, in table order.
    fn values(&self) -> Vec<(&'static str, Value)> {
        Self::SETTINGS
            .iter()
            .map(|s| {
                (
                    s.name,
                    self.get(s.name)
                        .expect("every described setting can be read"),
                )
            })
            .collect()
    }
}

/// A closed set of choices, each with the name users type; `Display` and
/// `FromStr` follow from it ([`named_choice!`](crate::named_choice)).
pub trait Choice: Copy + PartialEq + 'static {
    /// What a value is called in messages (`"oracle"`).
    const KIND: &'static str;
    /// Every value, in the order users see them.
    const ALL: &'static [Self];
    /// Their names, in the same order.
    const NAMES: &'static [&'static str];

    /// The name of `self`.
    fn name(self) -> &'static str {
        let i = Self::ALL
            .iter()
            .position(|c| *c == self)
            .expect("ALL lists every value");
        Self::NAMES[i]
    }

    /// The value called `name`.
    fn from_name(name: &str) -> Result<Self> {
        Self::NAMES
            .iter()
            .position(|n| *n == name)
            .map(|i| Self::ALL[i])
            .ok_or_else(|| {
                Error::InvalidSetting(format!(
                    "unknown {} {name:?} (expected one of: {})",
                    Self::KIND,
                    Self::NAMES.join(", ")
                ))
            })
    }

    /// `value` as this choice (a [`Value::Choice`] that a table checked).
    fn from_value(value: Value) -> Self {
        match value {
            Value::Choice(name) => Self::from_name(name).expect("checked against NAMES"),
            _ => unreachable!("checked to be a choice"),
        }
    }
}

/// `Display` and `FromStr` of a [`Choice`] from its names.
#[macro_export]
macro_rules! named_choice {
    ($ty:ty) => {
        impl ::std::fmt::Display for $ty {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str($crate::setting::Choice::name(*self))
            }
        }

        impl ::std::str::FromStr for $ty {
            type Err = $crate::Error;
            fn from_str(name: &str) -> $crate::Result<Self> {
                <$ty as $crate::setting::Choice>::from_name(name)
            }
        }
    };
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Every setting `S` describes reads back what was written, and writing
    /// a setting's own value changes nothing else.
    pub(crate) fn every_setting_reads_back<S: Described + Default + PartialEq + fmt::Debug>() {
        for setting in S::SETTINGS {
            let mut settings = S::default();
            let value = settings
                .get(setting.name)
                .expect("described settings can be read");
            settings.set(setting.name, value).unwrap();
            assert_eq!(settings.get(setting.name), Some(value), "{}", setting.name);
            assert_eq!(settings, S::default(), "{} wrote elsewhere", setting.name);
        }
    }

    const LEVEL: Setting = Setting {
        name: "max_level",
        group: Group::Solve,
        domain: Domain::Count { min: 0, max: 16 },
        default: "5",
        help: "",
    };

    #[test]
    fn parse_checks_the_range_and_names_the_setting() {
        assert_eq!(LEVEL.flag(), "--max-level");
        assert_eq!(LEVEL.parse("16").unwrap(), Value::Count(16));
        let message = LEVEL.parse("17").unwrap_err().to_string();
        assert!(
            message.contains("max_level") && message.contains("0..=16"),
            "{message}"
        );
        assert!(LEVEL.parse("-1").is_err() && LEVEL.parse("two").is_err());
        assert!(LEVEL.check(Value::Real(2.0)).is_err());
    }

    #[test]
    fn real_settings_refuse_non_finite_values() {
        let threshold = Setting {
            domain: Domain::Real { min: 0.0, max: 1.0 },
            ..LEVEL
        };
        assert_eq!(threshold.parse("1e-3").unwrap(), Value::Real(1e-3));
        for bad in ["nan", "inf", "-1e-9", "1.5"] {
            assert!(threshold.parse(bad).is_err(), "{bad}");
        }
    }

    #[derive(Debug, Clone, Copy, PartialEq)]
    enum Fruit {
        Apple,
        Pear,
    }
    impl Choice for Fruit {
        const KIND: &'static str = "fruit";
        const ALL: &'static [Self] = &[Fruit::Apple, Fruit::Pear];
        const NAMES: &'static [&'static str] = &["apple", "pear"];
    }
    crate::named_choice!(Fruit);

    #[test]
    fn choices_round_trip_through_their_names() {
        for &fruit in Fruit::ALL {
            assert_eq!(fruit.to_string().parse::<Fruit>().unwrap(), fruit);
        }
        let message = "plum".parse::<Fruit>().unwrap_err().to_string();
        assert!(message.contains("unknown fruit \"plum\"") && message.contains("apple, pear"));
    }
}
