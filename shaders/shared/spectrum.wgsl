// Spectra (dispersion): the index as a function of wavelength, the RGB → spectrum uplift,
// wavelength sampling and the CIE 1931 colour matching. The CPU twin, with the method and its
// sources, is src/cpu/spectrum.rs; its test checks that the constants here are its own.
//
// A path that carries a wavelength sets `path_wavelength` (nm); 0 means the path is RGB, and
// then every function here leaves what it is given exactly as it is — so a frame without
// dispersion renders bit for bit as it did before dispersion existed.

// The wavelength of the path being traced, nm (0: an RGB path).
var<private> path_wavelength: f32 = 0.0;
// Set when the path crossed a dispersive surface or medium at its wavelength (view rays turn
// only such samples into spectral ones).
var<private> path_dispersed: bool = false;

const Y_INTEGRAL: f32 = 106.92207;
// XYZ (÷ Y_INTEGRAL) → linear sRGB, white-balanced to the equal-energy spectrum; built from
// the rows of the matrix, so `xyz * XYZ_TO_RGB_ROWS` is the matrix times xyz.
const XYZ_TO_RGB_ROWS: mat3x3<f32> = mat3x3<f32>(
    2.6998618, -1.2806972, -0.4154018,
    -1.020112, 1.9749469, 0.043693516,
    0.061333258, -0.22463168, 1.1639005,
);
// Weight of lobe j (a column here) in each primary's spectrum (r, g, b): `PRIMARY_LOBES * lobes`.
const PRIMARY_LOBES: mat3x3<f32> = mat3x3<f32>(
    0.028008588, 0.03388967, 1.1798322,
    0.042200994, 1.3961977, 0.021566017,
    1.5148968, 0.3583481, 0.022125207,
);
const LOBE_CENTRES: vec3<f32> = vec3<f32>(454.0, 532.0, 636.0);
const LOBE_WIDTH: f32 = 25.0;

// KHR_materials_dispersion: n(λ) = max(n_d + (n_d − 1)/V_d · (523655/λ² − 1.5168), 1), with
// dispersion = 20/V_d. `ior` itself without a wavelength or without dispersion.
fn ior_at(ior: f32, dispersion: f32, lambda: f32) -> f32 {
    if dispersion <= 0.0 || lambda <= 0.0 {
        return ior;
    }
    return max(ior + (ior - 1.0) * (dispersion / 20.0) * (523655.0 / (lambda * lambda) - 1.5168), 1.0);
}

// k(λ) = (n(λ) − 1)/(n_d − 1) of a medium with this dispersion (gradient-index media).
fn dispersion_scale(dispersion: f32, lambda: f32) -> f32 {
    if dispersion <= 0.0 || lambda <= 0.0 {
        return 1.0;
    }
    return 1.0 + (dispersion / 20.0) * (523655.0 / (lambda * lambda) - 1.5168);
}

fn cmf_lobe(l: f32, mu: f32, below: f32, above: f32) -> f32 {
    let t = (l - mu) / select(above, below, l < mu);
    return exp(-0.5 * t * t);
}

// CIE 1931 2° x̄, ȳ, z̄ (Wyman, Sloan and Shirley 2013, multi-lobe fit).
fn cmf(l: f32) -> vec3<f32> {
    return vec3<f32>(
        1.056 * cmf_lobe(l, 599.8, 37.9, 31.0) + 0.362 * cmf_lobe(l, 442.0, 16.0, 26.7) - 0.065 * cmf_lobe(l, 501.1, 20.4, 26.2),
        0.821 * cmf_lobe(l, 568.8, 46.9, 40.5) + 0.286 * cmf_lobe(l, 530.9, 16.3, 31.1),
        1.217 * cmf_lobe(l, 437.0, 11.8, 36.0) + 0.681 * cmf_lobe(l, 459.0, 26.0, 13.8),
    );
}

fn xyz_to_rgb(xyz: vec3<f32>) -> vec3<f32> {
    return xyz * XYZ_TO_RGB_ROWS;
}

// The spectrum of rgb c at λ: the grey part flat, the rest from the primaries' lobes.
fn uplift(c: vec3<f32>, l: f32) -> f32 {
    let m = min(c.r, min(c.g, c.b));
    let t = (vec3<f32>(l) - LOBE_CENTRES) / LOBE_WIDTH;
    let lobes = exp(-0.5 * t * t);
    return m + dot(c - vec3<f32>(m), PRIMARY_LOBES * lobes);
}

// Wavelengths in [360, 830] nm with pdf ∝ 1/cosh²(0.0072 (λ − 538)).
fn sample_wavelength(u: f32) -> f32 {
    return 538.0 - 138.88889 * atanh(0.8569106 - 1.827502 * u);
}

fn wavelength_pdf(l: f32) -> f32 {
    let c = cosh(0.0072 * (l - 538.0));
    return 0.003939804 / (c * c);
}

// One wavelength sample of rgb c as tristimulus XYZ (÷ Y_INTEGRAL): its mean over λ ~ pdf is
// c's XYZ, so xyz_to_rgb of it tends to c.
fn sample_xyz(c: vec3<f32>, l: f32) -> vec3<f32> {
    return cmf(l) * (uplift(c, l) / (wavelength_pdf(l) * Y_INTEGRAL));
}

// A per-channel factor (a tint, an absorption coefficient) at the path's wavelength: the same
// for all three channels, which then carry XYZ; unchanged on an RGB path.
fn at_wavelength(c: vec3<f32>) -> vec3<f32> {
    if path_wavelength <= 0.0 {
        return c;
    }
    return vec3<f32>(uplift(c, path_wavelength));
}
