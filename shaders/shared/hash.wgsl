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

// The R₃ low-discrepancy sequence (Roberts 2018), x_i = fract(i·(1/φ₃, 1/φ₃², 1/φ₃³)) with φ₃ the
// plastic number 1.22074408…: each coordinate's step as a 32-bit fraction, so i·α wraps exactly
// and x_i = f32(i·α)·2⁻³².
const R3_ALPHA_1: u32 = 0xd1b54a33u;
const R3_ALPHA_2: u32 = 0xabc98389u;
const R3_ALPHA_3: u32 = 0x8cb92ba7u;
const FIXED_32_TO_UNIT: f32 = 2.3283064e-10;
