//! Runtime errors.

use core::fmt;

/// Why an asset cannot be used by the runtime.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RuntimeError {
    /// The container itself is invalid.
    Load(penumbra_asset::LoadError),
    /// The asset is of another kind.
    WrongKind {
        /// Expected kind.
        expected: &'static str,
        /// Found kind.
        found: String,
    },
    /// A required section is missing.
    MissingSection(&'static str),
    /// A section has the wrong type or shape.
    BadSection {
        /// Section name.
        name: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// An asset that cannot be used, with the reason (sections named at run time).
    Invalid(String),
}

impl fmt::Display for RuntimeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RuntimeError::Load(e) => write!(f, "{e}"),
            RuntimeError::WrongKind { expected, found } => write!(f, "expected a {expected} asset, found {found}"),
            RuntimeError::MissingSection(n) => write!(f, "required section {n:?} is missing"),
            RuntimeError::BadSection { name, reason } => write!(f, "section {name:?}: {reason}"),
            RuntimeError::Invalid(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for RuntimeError {}

impl From<penumbra_asset::LoadError> for RuntimeError {
    fn from(e: penumbra_asset::LoadError) -> Self {
        RuntimeError::Load(e)
    }
}
