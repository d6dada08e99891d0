//! Synthetic scenes with ground truth (to be written by the synth work).
//!
//! Contract other modules code against (names fixed, details free):
//! `Shape`, `Material`, `SceneOptions: Default`, `Scene { stack, lights, mask, normals, depth, albedo }`,
//! `default_lights(k) -> Lights`, `render(&SceneOptions) -> Result<Scene>`.
