//! Mesh sets: shared connectivity detection and consistent winding.
