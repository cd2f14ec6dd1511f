//! The library's error type. Every failure a user can cause (bad scene, missing mesh, bad
//! flag, unwritable output) is a variant that names where the problem is, so the CLI can
//! print one precise line and map it to an exit code (2 for bad input, 1 for internal).

use std::path::PathBuf;

/// Everything that can go wrong in fragtrace.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene file (TOML) is malformed or has an invalid value.
    #[error("{file}:{line}: {field}: {message}")]
    Scene {
        /// Scene file path (or `<builtin>`).
        file: String,
        /// 1-based line number, 0 when unknown.
        line: usize,
        /// Dotted field path, e.g. `objects[2].material.ior`.
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A mesh (OBJ/MTL) could not be found or parsed.
    #[error("{file}: {message}")]
    Mesh {
        /// Mesh file path.
        file: String,
        /// What is wrong with it.
        message: String,
    },
    /// A command-line value is invalid.
    #[error("{0}")]
    Usage(String),
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// Encoding or decoding an image failed.
    #[error("{path}: {message}")]
    Image {
        /// The file involved.
        path: PathBuf,
        /// The codec's message.
        message: String,
    },
    /// No usable OpenGL context (EGL missing, GL too old, extension missing).
    #[error("OpenGL unavailable: {0}")]
    GlUnavailable(String),
    /// A shader failed to compile or link.
    #[error("shader error in pass `{pass}` ({file}:{line}): {log}")]
    Shader {
        /// The pass whose program failed.
        pass: String,
        /// The GLSL source file the error points into.
        file: String,
        /// Line within that file (0 when the driver gave none).
        line: usize,
        /// The driver's info log.
        log: String,
    },
    /// A resource limit would be exceeded (texture size, index range, memory).
    #[error("limit exceeded: {0}")]
    Limit(String),
    /// A render's observer asked it to stop (`fragtrace view` when the camera moves); the
    /// caller that installed the observer expects it and never shows it to the user.
    #[error("render cancelled")]
    Cancelled,
    /// A GPU kernel whose loops were ended before its work was done (a driver's limit on
    /// loop iterations, such as llvmpipe's, or a traversal bug): its image would be missing
    /// rays. `--kernel auto` then renders with a fragment kernel instead.
    #[error("the compute kernel did not finish: {0}")]
    Unfinished(String),
    /// A bug or an unexpected driver failure.
    #[error("internal error: {0}")]
    Internal(String),
}

impl Error {
    /// Process exit code: 2 for errors caused by input, 1 for internal failures.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Scene { .. }
            | Error::Mesh { .. }
            | Error::Usage(_)
            | Error::Io { .. }
            | Error::Image { .. }
            | Error::Limit(_) => 2,
            Error::GlUnavailable(_) => 2,
            Error::Shader { .. } | Error::Internal(_) | Error::Unfinished(_) | Error::Cancelled => {
                1
            }
        }
    }

    /// Shorthand for a scene error.
    pub fn scene(
        file: impl Into<String>,
        line: usize,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Error::Scene {
            file: file.into(),
            line,
            field: field.into(),
            message: message.into(),
        }
    }
}

/// Result alias used across the crate.
pub type Result<T> = std::result::Result<T, Error>;
