//! Campaign errors: each names the file, the JSON path and what was expected.

/// One problem at one JSON path.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldProblem {
    pub path: String,
    pub message: String,
}

/// Why a campaign file was refused.
#[derive(Debug, thiserror::Error)]
pub enum CampaignError {
    #[error("{file}: cannot read the campaign file: {source}")]
    Read {
        file: String,
        source: std::io::Error,
    },
    #[error("{file}: {path}: {message}")]
    Parse {
        file: String,
        path: String,
        message: String,
    },
    #[error("{file}: {} problem(s):\n{}", problems.len(), problems.iter().map(|p| format!("  {file}: {}: {}", p.path, p.message)).collect::<Vec<_>>().join("\n"))]
    Invalid {
        file: String,
        problems: Vec<FieldProblem>,
    },
}
