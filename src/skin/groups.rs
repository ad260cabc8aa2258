//! Rotation groups: k-means clustering of skinning weights and deformation features (BDT Sec. 3.3, Eq. 15).
