//! refrakt: a headless GPU renderer for refractive media — glass, water, gradient-index lenses —
//! and the caustics and light shafts they throw, after Sun, Zhou, Stollnitz, Shi and Guo,
//! "Interactive Relighting of Dynamic Refractive Objects" (SIGGRAPH 2008).
//!
//! Data flow of a frame: a scene (Lua script or glTF file) is evaluated into a [`frame::FrameDesc`]; the
//! [`pipeline::Renderer`] turns that into an [`output::Image`] on the GPU.

pub mod bench;
pub mod bundle;
pub mod bvh;
pub mod cpu;
pub mod dump;
pub mod frame;
pub mod gltf;
pub mod gpu;
pub mod gpus;
pub mod lua;
pub mod output;
pub mod pipeline;
pub mod progress;
pub mod render;
pub mod scene;
pub mod serve;
pub mod warnings;
pub mod watch;
