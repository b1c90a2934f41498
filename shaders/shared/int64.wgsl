// Signed 64-bit integers for exact geometric predicates. WGSL has no 64-bit integer type, so
// a value is two u32 words (low, high) in two's complement. Only what the predicates of
// voxelize_mesh.wgsl need: products of 32-bit integers, sums, and signs. The CPU twin
// (src/cpu/mesh.rs) uses Rust's i64, and the results agree bit for bit as long as no value
// leaves the i64 range, which the coordinate bounds of voxelize_mesh.wgsl guarantee.

alias I64 = vec2<u32>;

fn i64_add(a: I64, b: I64) -> I64 {
    let low = a.x + b.x;
    return I64(low, a.y + b.y + select(0u, 1u, low < a.x));
}

fn i64_neg(a: I64) -> I64 {
    return i64_add(~a, I64(1u, 0u));
}

fn i64_sub(a: I64, b: I64) -> I64 {
    return i64_add(a, i64_neg(b));
}

fn i64_is_negative(a: I64) -> bool {
    return (a.y >> 31u) != 0u;
}

// −1, 0 or 1.
fn i64_sign(a: I64) -> i32 {
    if i64_is_negative(a) {
        return -1;
    }
    return select(1, 0, a.x == 0u && a.y == 0u);
}

// The full 64-bit product of two u32, from four 16 × 16-bit partial products.
fn u32_mul_wide(a: u32, b: u32) -> I64 {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let middle = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return I64((p00 & 0xffffu) | (middle << 16u), a1 * b1 + (p01 >> 16u) + (p10 >> 16u) + (middle >> 16u));
}

// a · b, exactly.
fn i64_mul(a: i32, b: i32) -> I64 {
    let m = u32_mul_wide(u32(abs(a)), u32(abs(b)));
    return select(m, i64_neg(m), (a < 0) != (b < 0));
}

// a · b for a product known to fit in 63 bits.
fn i64_mul_i32(a: I64, b: i32) -> I64 {
    let negative = i64_is_negative(a);
    let m = select(a, i64_neg(a), negative);
    let mb = u32(abs(b));
    let low = u32_mul_wide(m.x, mb);
    let p = I64(low.x, low.y + m.y * mb);
    return select(p, i64_neg(p), negative != (b < 0));
}

// Nearest f32 (for estimates only; every decision is made on the exact value).
fn i64_to_f32(a: I64) -> f32 {
    return f32(bitcast<i32>(a.y)) * 4294967296.0 + f32(a.x);
}
