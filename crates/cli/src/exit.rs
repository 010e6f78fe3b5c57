//! Error classification and exit codes.

/// Process exit codes (DESIGN §2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(i32)]
pub enum ExitCode {
    /// Success.
    Ok = 0,
    /// A bake ran but a requested quality gate failed.
    QualityGate = 1,
    /// Bad usage, config or input.
    BadInput = 2,
    /// Internal bug.
    Internal = 101,
}

/// An error with the exit code it maps to.
#[derive(Debug)]
pub struct CliError {
    /// Exit code.
    pub code: ExitCode,
    /// The error with its context chain.
    pub error: anyhow::Error,
}

impl CliError {
    /// Bad input (exit 2).
    pub fn input(error: impl Into<anyhow::Error>) -> Self {
        Self { code: ExitCode::BadInput, error: error.into() }
    }

    /// Internal bug (exit 101).
    pub fn internal(error: impl Into<anyhow::Error>) -> Self {
        Self { code: ExitCode::Internal, error: error.into() }
    }
}

impl<E: Into<anyhow::Error>> From<E> for CliError {
    fn from(e: E) -> Self {
        Self::input(e)
    }
}

/// Prints the error chain to stderr and returns its exit code.
#[allow(clippy::print_stderr)]
pub fn report(e: &CliError) -> ExitCode {
    let mut msg = format!("error: {}", e.error);
    for cause in e.error.chain().skip(1) {
        msg.push_str(&format!("\n  caused by: {cause}"));
    }
    if e.code == ExitCode::Internal {
        msg.push_str("\n  (this is a bug in penumbra; please report it)");
    }
    eprintln!("{msg}");
    e.code
}
