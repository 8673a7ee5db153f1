//! Placeholder (issue 8, in progress).
