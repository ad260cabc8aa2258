//! Mesh file formats (owned by the mesh-I/O work; see module docs there).
