//! Errors of the core library.

/// What can go wrong inside the method (file formats have their own errors in
/// `wavrad-io`).
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum Error {
    /// A setting is out of range.
    #[error("invalid setting: {0}")]
    InvalidSetting(String),
    /// The scene has no surfaces.
    #[error("the scene has no surfaces")]
    EmptyScene,
    /// A size or coordinate of the scene beyond what wavrad accepts
    /// ([`crate::scene::Scene::check_bounds`]).
    #[error("{0}")]
    OutOfBounds(String),
    /// Every pair of surfaces gets a link hierarchy, so the work grows with
    /// the square of the surface count; past the limit a solve would run for
    /// hours, so it is refused up front.
    #[error(
        "the scene has {surfaces} surfaces (two-sided ones count twice); the shooting solver \
         links every pair of surfaces, so it accepts at most {limit}: use the gathering \
         solver, which clusters them"
    )]
    TooManySurfaces {
        /// Surfaces in the scene.
        surfaces: usize,
        /// The most wavrad accepts.
        limit: usize,
    },
    /// Blocks of a planned projection ([`crate::solve::Plan`]) that are not
    /// its items once each: a block past its items, a gap or an overlap.
    #[error("blocks of a plan of {items} projection items: {problem}")]
    Blocks {
        /// The plan's projection items.
        items: usize,
        /// What does not fit.
        problem: String,
    },
    /// A solve cannot be resumed from the checkpoint given
    /// ([`crate::solve::checkpoint::resume`]).
    #[error("cannot resume: {0}")]
    Resume(String),
    /// No surface emits and no other light shines: the solution would be
    /// black everywhere.
    #[error(
        "the scene has no light: no area emitter, point, spot, directional, envmap or constant \
         emitter with positive radiance"
    )]
    NoLight,
    /// Gauss–Seidel's residual kept growing: the system does not conserve
    /// energy (a receiver's form factors, or a glossy BRDF's coefficients,
    /// sum to more than it can reflect).
    #[error(
        "the radiance solution diverges: after {sweeps} Gauss–Seidel sweeps its change per \
         sweep has grown past what light that is conserved allows (it grew in the last \
         {growing} sweeps in a row; residual {residual:.3e}); growing fastest: {}",
        surfaces.join(", ")
    )]
    Diverged {
        /// Sweeps done.
        sweeps: u32,
        /// Sweeps in a row, up to the last, that the change of power grew.
        growing: u32,
        /// The last sweep's residual.
        residual: f64,
        /// The surfaces whose radiance changed most in the last sweep,
        /// most first: name and index.
        surfaces: Vec<String>,
    },
    /// A rendered image has pixels that are not finite numbers.
    #[error(
        "{count} of the image's {total} pixels are not finite (infinite or NaN): the solution \
         is wrong, and no image is written"
    )]
    NonFinitePixels {
        /// Pixels with a channel that is infinite or NaN.
        count: usize,
        /// Pixels in the image.
        total: usize,
    },
    /// The driver asked a render to stop ([`crate::progress::Progress::interrupted`]).
    #[error("interrupted: the render stopped, and there is no image")]
    Interrupted,
    /// Rendering needs a sensor and the scene has none.
    #[error("the scene has no sensor to render from")]
    NoSensor,
    /// A sensor index past the scene's sensors.
    #[error(
        "sensor {index}: the scene has {count} sensor{}, numbered from 0",
        if *count == 1 { "" } else { "s" }
    )]
    NoSuchSensor {
        /// The index asked for.
        index: usize,
        /// The scene's sensors.
        count: usize,
    },
    /// A render option that the render mode has no use for.
    #[error("render mode {mode} cannot use {option}: {reason}")]
    RenderOption {
        /// The mode's user-facing name.
        mode: &'static str,
        /// The option, in words.
        option: &'static str,
        /// Why the mode has no use for it.
        reason: &'static str,
    },
}

/// Result with the core [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
