//! The user-facing settings of a render, described once
//! ([`crate::setting`]): the CLI's render options, the keyword arguments of
//! Python's `Solution.render` and the `render` object of the CLI's
//! statistics JSON.

use super::estimator::Mode;
use super::RenderSettings;
use crate::scene::RenderHints;
use crate::setting::{Choice, Described, Domain, Group, Setting, Value};
use crate::Result;

/// Most camera rays per pixel any setting may ask for (emitters' outlines
/// take sixteen times as many).
pub const MAX_SAMPLES_PER_PIXEL: u32 = 1 << 16;

impl Described for RenderSettings {
    const SETTINGS: &'static [Setting] = &[
        Setting {
            name: "mode",
            group: Group::Render,
            domain: Domain::Choice(Mode::NAMES),
            default: "gather",
            help: "What camera rays show: `gather`, a final gather over the solution at each \
                   visible point (the most accurate); or the solution read directly, no gather: \
                   `direct` (the light straight from the emitters evaluated per camera ray, the \
                   rest of the solution smooth except across occluders' edges; glossy surfaces' \
                   radiance towards the eye per element), `smooth` (the solution alone, all of \
                   it smooth: what a lightmap holds) or `haar` (piecewise constant, as solved).",
        },
        Setting {
            name: "spp",
            group: Group::Render,
            domain: Domain::Count {
                min: 1,
                max: MAX_SAMPLES_PER_PIXEL,
            },
            default: "256, or the scene sampler's sample_count if larger",
            help: "Camera rays per pixel where an edge shows; pixels that show one surface (as do \
                   their neighbours) get a quarter, emitters' outlines sixteen times as many.",
        },
        Setting {
            name: "gather_spp",
            group: Group::Render,
            domain: Domain::Count {
                min: 1,
                max: MAX_SAMPLES_PER_PIXEL,
            },
            default: "spp / 32",
            help: "With mode gather: of an interior pixel's camera rays, how many also \
                   final-gather (32 indirect rays each; every camera ray casts a shadow ray to the \
                   emitters); pixels with more camera rays gather in the same proportion, those \
                   with fewer (uniformly lit) as often, a caustic's receivers (diffuse surfaces \
                   facing a sharp glossy surface that mirrors an emitter) sixteen times as much.",
        },
        Setting {
            name: "eye",
            group: Group::Render,
            domain: Domain::Flag,
            default: "true",
            help: "With modes direct, smooth and haar, gather glossy surfaces' radiance towards \
                   this view once into the eye as a receiver (the paper's §6); off, it is read \
                   from the view-independent solution (directional radiance towards what the view \
                   ray meets beyond the eye, or towards an enclosure receiver): no per-view work, \
                   softer highlights. The final gather has no use for it.",
        },
        Setting {
            name: "gather_cache",
            group: Group::Render,
            domain: Domain::Flag,
            default: "true",
            help: "With mode gather: read the light beyond the emitters' from a view-independent \
                   final gather made once per texel of every diffuse surface (texels half an \
                   element wide, gathered when a view first shows them, shared by every view), \
                   wherever it varies slowly, and gather per camera ray only near other \
                   geometry; off, every gathering camera ray gathers.",
        },
        Setting {
            name: "seed",
            group: Group::Render,
            domain: Domain::Count {
                min: 0,
                max: u32::MAX,
            },
            default: "0",
            help: "Scrambles every pixel's samples, as Mitsuba's sampler `seed` does: renders \
                   with different seeds have independent noise (half the mean square of their \
                   difference is each one's variance).",
        },
    ];

    fn get(&self, name: &str) -> Option<Value> {
        let (mode, eye, gather_cache) = self.estimator.choices();
        Some(match name {
            "mode" => Value::Choice(mode.name()),
            "spp" => Value::Count(self.samples_per_pixel),
            "gather_spp" => Value::Count(self.gather_samples_per_pixel),
            "eye" => Value::Flag(eye),
            "gather_cache" => Value::Flag(gather_cache),
            "seed" => Value::Count(self.seed),
            _ => return None,
        })
    }

    fn set_checked(&mut self, name: &str, value: Value) -> Result<()> {
        let (mut mode, mut eye, mut gather_cache) = self.estimator.choices();
        match (name, value) {
            ("mode", value) => mode = Mode::from_value(value),
            ("eye", Value::Flag(on)) => eye = on,
            ("gather_cache", Value::Flag(on)) => gather_cache = on,
            ("spp", Value::Count(n)) => *self = self.with_samples_per_pixel(n),
            ("gather_spp", Value::Count(n)) => self.gather_samples_per_pixel = n,
            ("seed", Value::Count(n)) => self.seed = n,
            _ => unreachable!("{name} = {value:?} was checked against SETTINGS"),
        }
        self.estimator = mode.estimator(eye, gather_cache)?;
        Ok(())
    }
}

impl RenderSettings {
    /// The settings users gave by name for a view of a sensor whose
    /// sampler asked for `hints`: its defaults
    /// ([`RenderSettings::for_hints`]), then the camera rays (which set the
    /// gathering share's default), then the rest; the mode, eye and gather
    /// cache are checked together ([`Mode::estimator`]).
    pub fn from_values(hints: &RenderHints, given: &[(&str, Value)]) -> Result<RenderSettings> {
        let mut settings = RenderSettings::for_hints(hints);
        let first = |name: &str| name == "spp";
        for &(name, value) in given.iter().filter(|(name, _)| first(name)) {
            settings.set(name, value)?;
        }
        let mut choices = settings.estimator.choices();
        for &(name, value) in given.iter().filter(|(name, _)| !first(name)) {
            let value = Self::setting(name)?.check(value)?;
            match (name, value) {
                ("mode", value) => choices.0 = Mode::from_value(value),
                ("eye", Value::Flag(on)) => choices.1 = on,
                ("gather_cache", Value::Flag(on)) => choices.2 = on,
                _ => settings.set_checked(name, value)?,
            }
        }
        let (mode, eye, gather_cache) = choices;
        settings.estimator = mode.estimator(eye, gather_cache)?;
        Ok(settings)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::estimator::Estimator;

    fn no_hints() -> RenderHints {
        RenderHints::default()
    }

    #[test]
    fn every_setting_reads_back_what_was_written() {
        crate::setting::tests::every_setting_reads_back::<RenderSettings>();
    }

    #[test]
    fn every_mode_with_its_options_reads_back_as_given() {
        for &mode in Mode::ALL {
            for (eye, cache) in [(true, false), (false, true), (true, true)] {
                let Ok(estimator) = mode.estimator(eye, cache) else {
                    continue;
                };
                let (read, read_eye, read_cache) = estimator.choices();
                assert_eq!(read.estimator(read_eye, read_cache), Ok(estimator));
                assert_eq!((read, read_eye, read_cache), (mode, eye, cache));
            }
        }
    }

    #[test]
    fn options_are_checked_together_whatever_the_order() {
        let per_ray = [
            ("gather_cache", Value::Flag(false)),
            ("mode", Value::Choice("gather")),
        ];
        let settings = RenderSettings::from_values(&no_hints(), &per_ray).unwrap();
        assert_eq!(settings.estimator, Estimator::FinalGather { cached: false });
        let haar = [
            ("gather_cache", Value::Flag(false)),
            ("mode", Value::Choice("haar")),
        ];
        assert!(RenderSettings::from_values(&no_hints(), &haar).is_err());
        let no_eye = [("eye", Value::Flag(false))];
        assert!(RenderSettings::from_values(&no_hints(), &no_eye).is_err());
    }

    #[test]
    fn gathering_share_follows_the_camera_rays_unless_given() {
        let spp = ("spp", Value::Count(64));
        let gathers = ("gather_spp", Value::Count(5));
        let s = RenderSettings::from_values(&no_hints(), &[gathers, spp]).unwrap();
        assert_eq!((s.samples_per_pixel, s.gather_samples_per_pixel), (64, 5));
        let s = RenderSettings::from_values(&no_hints(), &[spp]).unwrap();
        assert_eq!((s.samples_per_pixel, s.gather_samples_per_pixel), (64, 2));
        assert!(RenderSettings::from_values(&no_hints(), &[("spp", Value::Count(0))]).is_err());
    }
}
