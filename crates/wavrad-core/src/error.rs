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
    /// Rendering needs a sensor and the scene has none.
    #[error("the scene has no sensor to render from")]
    NoSensor,
}

/// Result with the core [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
