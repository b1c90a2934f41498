//! Mutations of valid files for the property tests that fuzz refrakt's readers (glTF, images,
//! OBJ), and their bounded, reproducible configuration.

use proptest::prelude::*;

/// A mutation of a file: flip a byte, overwrite a little-endian u32 (lengths, offsets, counts),
/// or cut the file short.
#[derive(Clone, Debug)]
pub enum Mutation {
    Flip(usize, u8),
    Word(usize, u32),
    Cut(usize),
}

pub fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1..=255u8).prop_map(|(i, b)| Mutation::Flip(i, b)),
        (any::<usize>(), prop_oneof![Just(0u32), Just(u32::MAX), Just(1 << 30), 0..4096u32]).prop_map(|(i, w)| Mutation::Word(i, w)),
        any::<usize>().prop_map(Mutation::Cut),
    ]
}

pub fn mutate(mut bytes: Vec<u8>, ms: &[Mutation]) -> Vec<u8> {
    for m in ms {
        let n = bytes.len().max(1);
        match *m {
            Mutation::Flip(i, b) => {
                if let Some(x) = bytes.get_mut(i % n) {
                    *x ^= b;
                }
            }
            Mutation::Word(i, w) => {
                let i = (i % n) & !3;
                if i + 4 <= bytes.len() {
                    bytes[i..i + 4].copy_from_slice(&w.to_le_bytes());
                }
            }
            Mutation::Cut(i) => bytes.truncate(i % n),
        }
    }
    bytes
}

/// Bounded and reproducible for CI: 256 cases per property from a fixed seed. For a
/// longer search, set PROPTEST_CASES and PROPTEST_RNG_SEED (e.g. `PROPTEST_CASES=20000
/// PROPTEST_RNG_SEED=$RANDOM cargo test --release --test gltf_input mutated`; the other fuzz
/// properties: `--test fuzz_inputs`).
pub fn fuzz_config() -> ProptestConfig {
    let from_env = ProptestConfig::default();
    let set = |var: &str| std::env::var_os(var).is_some();
    ProptestConfig {
        cases: if set("PROPTEST_CASES") { from_env.cases } else { 256 },
        rng_seed: if set("PROPTEST_RNG_SEED") { from_env.rng_seed } else { proptest::test_runner::RngSeed::Fixed(0x05ee_d91f) },
        failure_persistence: None,
        ..from_env
    }
}

