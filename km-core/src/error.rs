//! Errors of the core library: one enum, every message names the offending value.

use thiserror::Error;

/// An error of the core library.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CoreError {
    /// A parameter outside its domain.
    #[error("invalid {name} = {value}: {reason}")]
    Invalid {
        /// Parameter name, as in the scene file.
        name: String,
        /// The offending value.
        value: f64,
        /// What the domain is.
        reason: String,
    },
    /// A scene file that cannot be used; `line` is 1-based when known.
    #[error("{}", scene_message(.key, *.line, .message))]
    Scene {
        /// Dotted key path, e.g. `layer[2].sigma_a`.
        key: String,
        /// 1-based line in the scene file, when known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A scene the chosen method cannot treat.
    #[error("method {method} cannot treat this scene: {reason}")]
    Unsupported {
        /// Method name.
        method: String,
        /// Why.
        reason: String,
    },
}

fn scene_message(key: &str, line: Option<usize>, message: &str) -> String {
    match line {
        Some(l) => format!("line {l}: `{key}`: {message}"),
        None => format!("`{key}`: {message}"),
    }
}

impl CoreError {
    /// A parameter outside its domain.
    pub fn invalid(name: &str, value: f64, reason: &str) -> Self {
        CoreError::Invalid { name: name.into(), value, reason: reason.into() }
    }
    /// A scene-file error at a key and line.
    pub fn scene(key: impl Into<String>, line: Option<usize>, message: impl Into<String>) -> Self {
        CoreError::Scene { key: key.into(), line, message: message.into() }
    }
    /// A scene the method cannot treat.
    pub fn unsupported(method: &str, reason: impl Into<String>) -> Self {
        CoreError::Unsupported { method: method.into(), reason: reason.into() }
    }
}
