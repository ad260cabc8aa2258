//! BDT pipeline: key point selection (Algorithm 1) and deformation transfer
//! (Sec. 3.6).

pub mod target;

pub use target::{
    handle_relative, mean_vertex_error, transfer, transfer_detailed, TransferFrame,
    TransferOptions, TransferResult,
};
