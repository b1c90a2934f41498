// Counter-based random numbers: a photon's randomness is a pure function of (seed, photon index,
// dimension), so the same photons leave the lights every frame (no flicker in animations) and
// the result does not depend on thread scheduling. PCG's output permutation (O'Neill 2014) as an
// integer hash, as recommended by Jarzynski & Olano, "Hash Functions for GPU Rendering", 2020.

fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// A uniform number in [0, 1) for (seed, index, dimension).
fn random01(seed: u32, index: u32, dimension: u32) -> f32 {
    let h = pcg_hash(pcg_hash(pcg_hash(seed) ^ index) + dimension);
    return f32(h >> 8u) * (1.0 / 16777216.0);
}
