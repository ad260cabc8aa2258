//! Defect report for one mesh.
