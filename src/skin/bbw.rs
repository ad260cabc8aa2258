//! Bounded biharmonic weights (BDT Eq. 1).
