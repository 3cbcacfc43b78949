//! The crate's one error type.
//!
//! Every message names where the problem is: `file:line: problem` for scene
//! files, the path for I/O, mesh and image problems.

use std::fmt;
use std::path::{Path, PathBuf};

/// Result alias used throughout `wavrad-io`.
pub type Result<T> = std::result::Result<T, Error>;

/// Everything that can go wrong while reading scenes and meshes or writing
/// images. The `Display` form is meant for users as is.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file in question.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// A scene description is malformed, inconsistent or uses something
    /// wavrad does not support.
    #[error("{file}:{line}: {message}")]
    Scene {
        /// The scene (or included) file, as named to the loader.
        file: String,
        /// 1-based line of the offending element.
        line: u32,
        /// What is wrong.
        message: String,
    },
    /// A mesh file (OBJ, PLY) is malformed or empty.
    #[error("{}: {message}", Located(path, *line))]
    Mesh {
        /// The mesh file.
        path: PathBuf,
        /// 1-based line, for text formats when known.
        line: Option<u32>,
        /// What is wrong.
        message: String,
    },
    /// An image could not be encoded or decoded, or its arguments are
    /// inconsistent.
    #[error("{}: {message}", path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A block of projected links ([`crate::block_links`]) is not one, is
    /// damaged, or was projected from another plan.
    #[error("block of links: {message}")]
    BlockLinks {
        /// What is wrong.
        message: String,
    },
    /// A solution file ([`crate::solution_file`]) is not one, is of
    /// another format version, is truncated or damaged, or its scene
    /// changed since the solve.
    #[error("{}: {problem}", path.display())]
    Solution {
        /// The solution file.
        path: PathBuf,
        /// What is wrong.
        problem: crate::solution_file::SolutionProblem,
    },
}

impl Error {
    /// An I/O error about `path`.
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Error {
        Error::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    /// An image error about `path`.
    pub(crate) fn image(path: &Path, message: impl Into<String>) -> Error {
        Error::Image {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    /// A solution file's `problem`.
    pub(crate) fn solution(path: &Path, problem: crate::solution_file::SolutionProblem) -> Error {
        Error::Solution {
            path: path.to_path_buf(),
            problem,
        }
    }

    /// A mesh error about `path`, at `line` when known.
    pub(crate) fn mesh(path: &Path, line: Option<u32>, message: impl Into<String>) -> Error {
        Error::Mesh {
            path: path.to_path_buf(),
            line,
            message: message.into(),
        }
    }
}

/// `path` or `path:line`.
struct Located<'a>(&'a Path, Option<u32>);

impl fmt::Display for Located<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.1 {
            Some(line) => write!(f, "{}:{line}", self.0.display()),
            None => write!(f, "{}", self.0.display()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_file_and_line() {
        let e = Error::Scene {
            file: "scenes/x.xml".into(),
            line: 12,
            message: "unsupported shape plugin \"sphere\"".into(),
        };
        assert_eq!(
            e.to_string(),
            "scenes/x.xml:12: unsupported shape plugin \"sphere\""
        );
        let m = Error::mesh(Path::new("a.ply"), Some(7), "bad vertex");
        assert_eq!(m.to_string(), "a.ply:7: bad vertex");
        let m = Error::mesh(Path::new("a.ply"), None, "no faces");
        assert_eq!(m.to_string(), "a.ply: no faces");
    }

    #[test]
    fn error_is_send_and_sync() {
        fn check<T: Send + Sync + 'static>() {}
        check::<Error>();
    }
}
