//! Dataset layouts, synthetic data and correspondence files.
