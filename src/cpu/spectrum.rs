//! Spectra: the index as a function of wavelength, the RGB → spectrum uplift, wavelength
//! sampling and the CIE 1931 colour matching — the CPU twin of `shaders/shared/spectrum.wgsl`
//! (the same constants, checked against the WGSL text by a test below).
//!
//! - **n(λ)** is KHR_materials_dispersion's: n(λ) = max(n_d + (n_d − 1)/V_d · (523655/λ² −
//!   1.5168), 1), λ in nm, V_d the Abbe number and `dispersion` = 20/V_d (0: none).
//! - **Colour matching**: the CIE 1931 2° observer as the multi-lobe Gaussian fit of Wyman,
//!   Sloan and Shirley (JCGT 2013; within about 1 % of the tabulated functions), then XYZ →
//!   linear sRGB (IEC 61966-2-1), white-balanced so that the equal-energy spectrum is exactly
//!   (1, 1, 1): the matrix is `XYZ_TO_RGB` below.
//! - **Uplift** (what spectrum an rgb colour of light, a tint or an absorption coefficient is):
//!   rgb = m + (rgb − m) with m = min(r, g, b); the grey part m is the flat (equal-energy)
//!   spectrum, the rest a non-negative mix of three Gaussian lobes (454, 532 and 636 nm, σ = 25
//!   nm) whose weights `PRIMARY_LOBES` make each primary project back to itself exactly. So every
//!   colour's spectrum is non-negative, white is flat (a prism spreads it into a continuous
//!   rainbow, not three bands) and projects back to the rgb it came from: light through glass
//!   without dispersion keeps its colour exactly, in expectation over wavelengths.
//! - **Sampling**: wavelengths in [360, 830] nm from a density constant over 10 nm bins, each
//!   bin's weight the mean there of |M·x̄ȳz̄(λ)| (M the XYZ → sRGB matrix; 1 % spread evenly): the
//!   density that makes a white photon's rgb the least noisy (`wavelength_cdf`). Against pbrt-v4's
//!   visible-wavelength density 1/cosh²(0.0072 (λ − 538)), which follows the eye's luminance and
//!   so undersamples the blue and deep red that the sRGB primaries weigh heavily, it cuts that
//!   noise's variance from 13.3 to 8.8 (summed over r, g, b, each of mean 1) and the largest
//!   weight a wavelength gives a channel from 7.7× to 5.6×.

use glam::{Mat3, Vec3};

pub const LAMBDA_MIN: f32 = 360.0;
pub const LAMBDA_MAX: f32 = 830.0;

/// Fraunhofer lines the Abbe number is defined by (nm): F (blue), d (helium yellow), C (red).
pub const LAMBDA_F: f32 = 486.1;
pub const LAMBDA_D: f32 = 587.6;
pub const LAMBDA_C: f32 = 656.3;

/// The index at wavelength `lambda` (nm) of a material with index `ior` (n_d) and KHR
/// `dispersion` (20/V_d; 0 = none, then exactly `ior`).
pub fn ior_at(ior: f32, dispersion: f32, lambda: f32) -> f32 {
    if dispersion <= 0.0 {
        return ior;
    }
    (ior + (ior - 1.0) * (dispersion / 20.0) * (523655.0 / (lambda * lambda) - 1.5168)).max(1.0)
}

/// KHR `dispersion` from an Abbe number V_d (0 or absent: none).
pub fn dispersion_from_abbe(abbe: f32) -> f32 {
    if abbe > 0.0 { 20.0 / abbe } else { 0.0 }
}

fn lobe(lambda: f32, mu: f32, below: f32, above: f32) -> f32 {
    let s = if lambda < mu { below } else { above };
    let t = (lambda - mu) / s;
    (-0.5 * t * t).exp()
}

/// CIE 1931 2° colour matching functions x̄, ȳ, z̄ at `lambda` nm (Wyman et al. 2013, multi-lobe).
pub fn cmf(lambda: f32) -> Vec3 {
    let l = lambda;
    Vec3::new(
        1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7) - 0.065 * lobe(l, 501.1, 20.4, 26.2),
        0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1),
        1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8),
    )
}

/// ∫ȳ dλ over [LAMBDA_MIN, LAMBDA_MAX] (nm): tristimulus values are divided by it, so the flat
/// spectrum of radiance 1 has Y = 1.
pub const Y_INTEGRAL: f32 = 106.922_074;

/// XYZ (normalised by `Y_INTEGRAL`) → linear sRGB, white-balanced to the equal-energy
/// spectrum, rows. (IEC 61966-2-1's matrix with each row divided by the equal-energy white's
/// value in it.)
pub const XYZ_TO_RGB: [[f32; 3]; 3] = [
    [2.699_861_743, -1.280_697_238, -0.415_401_797_5],
    [-1.020_111_988, 1.974_946_915, 0.043_693_515_83],
    [0.061_333_258_53, -0.224_631_683, 1.163_900_436],
];

/// Centres of the uplift's three lobes (nm) and their common width σ.
pub const LOBE_CENTRES: [f32; 3] = [454.0, 532.0, 636.0];
pub const LOBE_WIDTH: f32 = 25.0;

/// Weight of lobe j (row) in primary c's spectrum (column: red, green, blue), all ≥ 0.
pub const PRIMARY_LOBES: [[f32; 3]; 3] = [
    [0.028_008_587_3, 0.033_889_671_04, 1.179_832_233],
    [0.042_200_995_18, 1.396_197_663, 0.021_566_016_15],
    [1.514_896_799, 0.358_348_087, 0.022_125_207_45],
];

pub fn xyz_to_rgb(xyz: Vec3) -> Vec3 {
    Mat3::from_cols_array_2d(&XYZ_TO_RGB).transpose() * xyz
}

/// The spectrum of rgb `c` at `lambda`: its grey part flat, the rest from the primaries' lobes.
pub fn uplift(c: Vec3, lambda: f32) -> f32 {
    let m = c.min_element();
    let lobes = Vec3::from(LOBE_CENTRES.map(|mu| lobe(lambda, mu, LOBE_WIDTH, LOBE_WIDTH)));
    // Column j of this matrix is row j of PRIMARY_LOBES: lobe j's weight in each primary.
    let primaries = Mat3::from_cols_array_2d(&PRIMARY_LOBES) * lobes;
    m + (c - Vec3::splat(m)).dot(primaries)
}

/// Width of the bins of the wavelength density (nm): `WAVELENGTH_BINS` of them span
/// [LAMBDA_MIN, LAMBDA_MAX].
pub const WAVELENGTH_BIN_WIDTH: f32 = 10.0;
pub const WAVELENGTH_BINS: usize = 47;

/// Share of the wavelength density spread evenly over the spectrum, so every wavelength keeps
/// a chance (a coloured light's spectrum may lie where the white target is small).
#[cfg(test)]
const WAVELENGTH_FLOOR: f64 = 0.01;

/// The CDF of the wavelength density at the bins' edges: `WAVELENGTH_CDF[k]` is the chance of a
/// wavelength below LAMBDA_MIN + k·WAVELENGTH_BIN_WIDTH. `wavelength_cdf()` computes it; a test
/// checks these digits against it and against spectrum.wgsl.
pub const WAVELENGTH_CDF: [f32; WAVELENGTH_BINS + 1] = [
    0.0, 0.00024902335, 0.00059243554, 0.0012113262, 0.002597754, 0.0066173514, 0.019673122, 0.05269112,
    0.104885675, 0.1619839, 0.2175733, 0.26536024, 0.29881245, 0.32137853, 0.34298623, 0.37080705,
    0.4078319, 0.45248356, 0.4988021, 0.54263103, 0.58249396, 0.6202729, 0.66060966, 0.7072208,
    0.76039535, 0.81685627, 0.8702934, 0.91512316, 0.9485839, 0.9708715, 0.98415357, 0.9912621,
    0.99471146, 0.99627215, 0.9969829, 0.99736136, 0.99762756, 0.9978596, 0.9980802, 0.99829614,
    0.99851006, 0.9987232, 0.9989361, 0.9991489, 0.9993617, 0.9995745, 0.9997872, 1.0,
];

/// The wavelength density's CDF at the bins' edges, from the colour matching functions. A white
/// light's photon of wavelength λ carries rgb w(λ)/p(λ) with w(λ) = M·x̄ȳz̄(λ)/Y_INTEGRAL (M =
/// `XYZ_TO_RGB`); the sum over channels of its second moment, ∫ |w(λ)|²/p(λ) dλ, is least for
/// p ∝ |w(λ)| (Cauchy–Schwarz). Each bin takes that target's mean over it (plus the floor).
/// (Only the tests compute it: the renderer uses the table.)
#[cfg(test)]
fn wavelength_cdf() -> [f32; WAVELENGTH_BINS + 1] {
    let m = glam::DMat3::from_cols_array_2d(&XYZ_TO_RGB.map(|r| r.map(f64::from))).transpose();
    let target = |l: f64| (m * cmf(l as f32).as_dvec3()).length();
    let per_bin: Vec<f64> = (0..WAVELENGTH_BINS)
        .map(|k| {
            // Midpoint rule at 0.1 nm within the bin.
            let start = f64::from(LAMBDA_MIN) + k as f64 * f64::from(WAVELENGTH_BIN_WIDTH);
            (0..100).map(|i| target(start + 0.1 * (i as f64 + 0.5))).sum::<f64>() * 0.1
        })
        .collect();
    let total: f64 = per_bin.iter().sum();
    let mut cdf = [0.0f32; WAVELENGTH_BINS + 1];
    let mut sum = 0.0;
    for (k, p) in per_bin.iter().enumerate() {
        sum += (1.0 - WAVELENGTH_FLOOR) * p / total + WAVELENGTH_FLOOR / WAVELENGTH_BINS as f64;
        cdf[k + 1] = sum as f32;
    }
    cdf[WAVELENGTH_BINS] = 1.0;
    cdf
}

/// A wavelength (nm) for a uniform number u in [0, 1): the bin whose CDF interval holds u, then
/// linearly within it (the inverse CDF of `wavelength_pdf`).
pub fn sample_wavelength(u: f32) -> f32 {
    let k = WAVELENGTH_CDF[1..WAVELENGTH_BINS].partition_point(|&c| c <= u);
    let f = (u - WAVELENGTH_CDF[k]) / (WAVELENGTH_CDF[k + 1] - WAVELENGTH_CDF[k]);
    LAMBDA_MIN + WAVELENGTH_BIN_WIDTH * (k as f32 + f)
}

/// The density `sample_wavelength` draws from, per nm: constant over each bin.
pub fn wavelength_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let k = (((lambda - LAMBDA_MIN) / WAVELENGTH_BIN_WIDTH) as usize).min(WAVELENGTH_BINS - 1);
    (WAVELENGTH_CDF[k + 1] - WAVELENGTH_CDF[k]) / WAVELENGTH_BIN_WIDTH
}

/// What one wavelength sample of rgb `c` contributes, as tristimulus XYZ (÷ `Y_INTEGRAL`):
/// x̄ȳz̄(λ) S(λ) / p(λ). Its expectation over λ ~ p is `c`'s XYZ, so `xyz_to_rgb` of the mean
/// of many samples tends to `c`.
pub fn sample_xyz(c: Vec3, lambda: f32) -> Vec3 {
    cmf(lambda) * (uplift(c, lambda) / (wavelength_pdf(lambda) * Y_INTEGRAL))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ f over [360, 830] nm by the trapezoid rule at 0.25 nm.
    fn integrate(f: impl Fn(f32) -> Vec3) -> Vec3 {
        let n = ((LAMBDA_MAX - LAMBDA_MIN) / 0.25) as usize;
        (0..=n).map(|i| f(LAMBDA_MIN + 0.25 * i as f32) * if i == 0 || i == n { 0.125 } else { 0.25 }).sum()
    }

    #[test]
    fn flat_spectrum_is_white_and_primaries_round_trip() {
        for c in [Vec3::ONE, Vec3::X, Vec3::Y, Vec3::Z, Vec3::new(0.2, 0.5, 0.9), Vec3::new(1.0, 0.9, 0.7)] {
            let rgb = xyz_to_rgb(integrate(|l| cmf(l) * uplift(c, l)) / Y_INTEGRAL);
            assert!((rgb - c).abs().max_element() < 2e-4, "{c} → {rgb}");
        }
        assert!((integrate(cmf).y / Y_INTEGRAL - 1.0).abs() < 1e-5);
    }

    #[test]
    fn uplifted_spectra_are_non_negative() {
        for c in [Vec3::X, Vec3::Y, Vec3::Z, Vec3::new(0.0, 0.3, 1.0), Vec3::new(1.0, 1.0, 0.0)] {
            for l in (360..=830).step_by(5) {
                assert!(uplift(c, l as f32) >= 0.0, "{c} at {l} nm");
            }
        }
    }

    #[test]
    fn wavelength_sampling_inverts_its_pdf() {
        let total = integrate(|l| Vec3::splat(wavelength_pdf(l))).x;
        assert!((total - 1.0).abs() < 1e-3, "pdf integrates to {total}");
        // The CDF of the sampled wavelength at u equals u.
        for u in [0.05f32, 0.25, 0.5, 0.75, 0.95] {
            let l = sample_wavelength(u);
            let cdf = integrate(|x| Vec3::splat(if x <= l { wavelength_pdf(x) } else { 0.0 })).x;
            assert!((cdf - u).abs() < 2e-3, "u = {u}: λ = {l}, CDF {cdf}");
        }
    }

    #[test]
    fn wavelength_cdf_is_the_one_computed() {
        for (k, (table, computed)) in WAVELENGTH_CDF.iter().zip(wavelength_cdf()).enumerate() {
            assert!((table - computed).abs() < 1e-6, "edge {k}: {table} vs {computed}");
        }
    }

    /// The sum over channels of a white photon's rgb second moment, Σ_c ∫ w_c(λ)²/p(λ) dλ
    /// (each channel's mean is 1): 13.3 with the cosh⁻² density refrakt drew from before; with
    /// the binned |w| density a spectral caustic needs about 35 % fewer photons for its noise.
    #[test]
    fn binned_density_lowers_the_colour_noise_of_white_light() {
        let m = Mat3::from_cols_array_2d(&XYZ_TO_RGB).transpose();
        let second_moment = integrate(|l| {
            let w = m * cmf(l) / Y_INTEGRAL;
            w * w / wavelength_pdf(l)
        });
        let mean = integrate(|l| m * cmf(l) / Y_INTEGRAL);
        assert!((mean - Vec3::ONE).abs().max_element() < 1e-4, "{mean}");
        let variance = (second_moment - Vec3::ONE).element_sum();
        assert!((8.7..9.0).contains(&variance), "colour variance {variance}");
    }

    #[test]
    fn wgsl_constants_are_these() {
        let wgsl = include_str!("../../shaders/shared/spectrum.wgsl");
        let mut all: Vec<f32> = vec![Y_INTEGRAL, LOBE_WIDTH];
        all.extend(XYZ_TO_RGB.iter().flatten());
        all.extend(PRIMARY_LOBES.iter().flatten());
        all.extend(LOBE_CENTRES);
        all.extend(WAVELENGTH_CDF);
        for v in all {
            assert!(wgsl.contains(&format!("{v:?}")), "spectrum.wgsl lacks {v:?}");
        }
    }
}
