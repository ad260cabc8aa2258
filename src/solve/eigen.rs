//! Generalised symmetric eigenpairs (placeholder, being written).
