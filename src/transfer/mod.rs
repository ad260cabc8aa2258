//! BDT pipeline: key point selection (Algorithm 1) and deformation transfer
//! (Sec. 3.6).
