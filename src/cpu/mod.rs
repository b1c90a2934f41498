//! CPU twins of the GPU kernels: the same algorithms as plain loops, used only by tests to find
//! GPU bugs (run both on one input and compare) and to check the numerics against closed forms.

pub mod dda;
pub mod field;
pub mod interface;
pub mod mesh;
pub mod octree;
pub mod pbr;
pub mod ray;
pub mod spectrum;
