//! Reduced (skinning-subspace) as-rigid-as-possible deformation with the
//! E_diff data term, solved local/global (BDT Eq. 3–5, 16–21).
