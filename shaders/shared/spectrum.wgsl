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

// Wavelengths in [360, 830] nm from a density constant over 47 bins of 10 nm, each bin's weight
// the mean there of |M·x̄ȳz̄(λ)| (M the XYZ → sRGB matrix): the density under which a white
// photon's rgb is least noisy (src/cpu/spectrum.rs `wavelength_cdf`). WAVELENGTH_CDF[k] is the
// chance of a wavelength below 360 + 10k nm.
const WAVELENGTH_BINS: u32 = 47u;
const WAVELENGTH_BIN_WIDTH: f32 = 10.0;
const WAVELENGTH_CDF = array<f32, 48>(
    0.0, 0.00024902335, 0.00059243554, 0.0012113262, 0.002597754, 0.0066173514, 0.019673122, 0.05269112,
    0.104885675, 0.1619839, 0.2175733, 0.26536024, 0.29881245, 0.32137853, 0.34298623, 0.37080705,
    0.4078319, 0.45248356, 0.4988021, 0.54263103, 0.58249396, 0.6202729, 0.66060966, 0.7072208,
    0.76039535, 0.81685627, 0.8702934, 0.91512316, 0.9485839, 0.9708715, 0.98415357, 0.9912621,
    0.99471146, 0.99627215, 0.9969829, 0.99736136, 0.99762756, 0.9978596, 0.9980802, 0.99829614,
    0.99851006, 0.9987232, 0.9989361, 0.9991489, 0.9993617, 0.9995745, 0.9997872, 1.0,
);

// The inverse CDF: the bin whose CDF interval holds u (a binary search over the 47), then
// linearly within it.
fn sample_wavelength(u: f32) -> f32 {
    var k = 0u;
    for (var step = 32u; step > 0u; step >>= 1u) {
        let next = k + step;
        if next < WAVELENGTH_BINS && WAVELENGTH_CDF[next] <= u {
            k = next;
        }
    }
    let f = (u - WAVELENGTH_CDF[k]) / (WAVELENGTH_CDF[k + 1u] - WAVELENGTH_CDF[k]);
    return 360.0 + WAVELENGTH_BIN_WIDTH * (f32(k) + f);
}

fn wavelength_pdf(l: f32) -> f32 {
    let k = min(u32(max(l - 360.0, 0.0) / WAVELENGTH_BIN_WIDTH), WAVELENGTH_BINS - 1u);
    return (WAVELENGTH_CDF[k + 1u] - WAVELENGTH_CDF[k]) / WAVELENGTH_BIN_WIDTH;
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
