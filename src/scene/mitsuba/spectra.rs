//! Spectra given by wavelengths (`<spectrum value="400:0.343, 404:0.445, ...">`) as the RGB colour
//! Mitsuba 3's RGB variants (`llvm_ad_rgb`, `scalar_rgb`) make of them when they load the file. vkpath
//! renders in RGB, so this is the same colour Mitsuba renders with, not an approximation of a spectral
//! render.
//!
//! The rule (Mitsuba 3.9.1's XML loader, checked against its `eval_diffuse_reflectance` and emitter
//! `eval` to 1e-6 on Mitsuba's own cbox.xml):
//!
//!   XYZ = (1 / S_y) sum_i  cmf(l_i) v(l_i) w(l_i) dl,   l_i = 360 + i (830 - 360) / 999,  i = 0..999,
//!   dl = (830 - 360) / 1000 nm,   S_y = sum_i ybar(l_i) dl (= 106.75, the integral of ybar),
//!
//! with v the spectrum linearly interpolated between its samples and zero outside them, cmf the CIE 1931
//! 2-degree colour matching functions (x̄, ȳ, z̄) and w the CIE D65 illuminant scaled to about 1 at 560 nm
//! for a *bounded* spectrum (a reflectance: any parameter outside an emitter, except the unbounded eta,
//! k, int_ior and ext_ior), 1 otherwise (an emitter's radiance). Weighting a reflectance by D65, sRGB's
//! white, makes a flat reflectance grey. Then linear sRGB = M XYZ (IEC 61966-2-1's matrix, as Mitsuba
//! writes it), clamped to [0, 1] when bounded and to >= 0 otherwise (Mitsuba clamps too, with a warning).

use glam::{DMat3, DVec3};

/// The first tabulated wavelength and the spacing of [`CIE`] (nm).
const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;
const CIE_STEP: f64 = 5.0;

/// D65's scale in [`CIE`]: the CIE's relative spectral power (100 at 560 nm) over this, Mitsuba's
/// normalisation of the illuminant.
const D65_SCALE: f64 = 98.99741751876255;

/// CIE 1931 2-degree observer x̄, ȳ, z̄ and the CIE standard illuminant D65's relative spectral power, at 5 nm
/// from 360 to 830 nm (CIE 015:2018, tables of the standard observer and illuminant; public data).
#[rustfmt::skip]
const CIE: [[f64; 4]; 95] = [
    [0.0001299, 3.917e-06, 0.0006061, 46.6383], // 360 nm
    [0.0002321, 6.965e-06, 0.001086, 49.3637], // 365 nm
    [0.0004149, 1.239e-05, 0.001946, 52.0891], // 370 nm
    [0.0007416, 2.202e-05, 0.003486, 51.0323], // 375 nm
    [0.001368, 3.9e-05, 0.006450001, 49.9755], // 380 nm
    [0.002236, 6.4e-05, 0.01054999, 52.3118], // 385 nm
    [0.004243, 0.00012, 0.02005001, 54.6482], // 390 nm
    [0.00765, 0.000217, 0.03621, 68.7015], // 395 nm
    [0.01431, 0.000396, 0.06785001, 82.7549], // 400 nm
    [0.02319, 0.00064, 0.1102, 87.1204], // 405 nm
    [0.04351, 0.00121, 0.2074, 91.486], // 410 nm
    [0.07763, 0.00218, 0.3713, 92.4589], // 415 nm
    [0.13438, 0.004, 0.6456, 93.4318], // 420 nm
    [0.21477, 0.0073, 1.0390501, 90.057], // 425 nm
    [0.2839, 0.0116, 1.3856, 86.6823], // 430 nm
    [0.3285, 0.01684, 1.62296, 95.7736], // 435 nm
    [0.34828, 0.023, 1.74706, 104.865], // 440 nm
    [0.34806, 0.0298, 1.7826, 110.936], // 445 nm
    [0.3362, 0.038, 1.77211, 117.008], // 450 nm
    [0.3187, 0.048, 1.7441, 117.41], // 455 nm
    [0.2908, 0.06, 1.6692, 117.812], // 460 nm
    [0.2511, 0.0739, 1.5281, 116.336], // 465 nm
    [0.19536, 0.09098, 1.28764, 114.861], // 470 nm
    [0.1421, 0.1126, 1.0419, 115.392], // 475 nm
    [0.09564, 0.13902, 0.8129501, 115.923], // 480 nm
    [0.05795001, 0.1693, 0.6162, 112.367], // 485 nm
    [0.03201, 0.20802, 0.46518, 108.811], // 490 nm
    [0.0147, 0.2586, 0.3533, 109.082], // 495 nm
    [0.0049, 0.323, 0.272, 109.354], // 500 nm
    [0.0024, 0.4073, 0.2123, 108.578], // 505 nm
    [0.0093, 0.503, 0.1582, 107.802], // 510 nm
    [0.0291, 0.6082, 0.1117, 106.296], // 515 nm
    [0.06327, 0.71, 0.07824999, 104.79], // 520 nm
    [0.1096, 0.7932, 0.05725001, 106.239], // 525 nm
    [0.1655, 0.862, 0.04216, 107.689], // 530 nm
    [0.2257499, 0.9148501, 0.02984, 106.047], // 535 nm
    [0.2904, 0.954, 0.0203, 104.405], // 540 nm
    [0.3597, 0.9803, 0.0134, 104.225], // 545 nm
    [0.4334499, 0.9949501, 0.008749999, 104.046], // 550 nm
    [0.5120501, 1.0, 0.005749999, 102.023], // 555 nm
    [0.5945, 0.995, 0.0039, 100.0], // 560 nm
    [0.6784, 0.9786, 0.002749999, 98.1671], // 565 nm
    [0.7621, 0.952, 0.0021, 96.3342], // 570 nm
    [0.8425, 0.9154, 0.0018, 96.0611], // 575 nm
    [0.9163, 0.87, 0.001650001, 95.788], // 580 nm
    [0.9786, 0.8163, 0.0014, 92.2368], // 585 nm
    [1.0263, 0.757, 0.0011, 88.6856], // 590 nm
    [1.0567, 0.6949, 0.001, 89.3459], // 595 nm
    [1.0622, 0.631, 0.0008, 90.0062], // 600 nm
    [1.0456, 0.5668, 0.0006, 89.8026], // 605 nm
    [1.0026, 0.503, 0.00034, 89.5991], // 610 nm
    [0.9384, 0.4412, 0.00024, 88.6489], // 615 nm
    [0.8544499, 0.381, 0.00019, 87.6987], // 620 nm
    [0.7514, 0.321, 1e-04, 85.4936], // 625 nm
    [0.6424, 0.265, 4.999999e-05, 83.2886], // 630 nm
    [0.5419, 0.217, 3e-05, 83.4939], // 635 nm
    [0.4479, 0.175, 2e-05, 83.6992], // 640 nm
    [0.3608, 0.1382, 1e-05, 81.863], // 645 nm
    [0.2835, 0.107, 0.0, 80.0268], // 650 nm
    [0.2187, 0.0816, 0.0, 80.1207], // 655 nm
    [0.1649, 0.061, 0.0, 80.2146], // 660 nm
    [0.1212, 0.04458, 0.0, 81.2462], // 665 nm
    [0.0874, 0.032, 0.0, 82.2778], // 670 nm
    [0.0636, 0.0232, 0.0, 80.281], // 675 nm
    [0.04677, 0.017, 0.0, 78.2842], // 680 nm
    [0.0329, 0.01192, 0.0, 74.0027], // 685 nm
    [0.0227, 0.00821, 0.0, 69.7213], // 690 nm
    [0.01584, 0.005723, 0.0, 70.6652], // 695 nm
    [0.01135916, 0.004102, 0.0, 71.6091], // 700 nm
    [0.008110916, 0.002929, 0.0, 72.979], // 705 nm
    [0.005790346, 0.002091, 0.0, 74.349], // 710 nm
    [0.004109457, 0.001484, 0.0, 67.9765], // 715 nm
    [0.002899327, 0.001047, 0.0, 61.604], // 720 nm
    [0.00204919, 0.00074, 0.0, 65.7448], // 725 nm
    [0.001439971, 0.00052, 0.0, 69.8856], // 730 nm
    [0.0009999493, 0.0003611, 0.0, 72.4863], // 735 nm
    [0.0006900786, 0.0002492, 0.0, 75.087], // 740 nm
    [0.0004760213, 0.0001719, 0.0, 69.3398], // 745 nm
    [0.0003323011, 0.00012, 0.0, 63.5927], // 750 nm
    [0.0002348261, 8.48e-05, 0.0, 55.0054], // 755 nm
    [0.0001661505, 6e-05, 0.0, 46.4182], // 760 nm
    [0.000117413, 4.24e-05, 0.0, 56.6118], // 765 nm
    [8.307527e-05, 3e-05, 0.0, 66.8054], // 770 nm
    [5.870652e-05, 2.12e-05, 0.0, 65.0941], // 775 nm
    [4.150994e-05, 1.499e-05, 0.0, 63.3828], // 780 nm
    [2.935326e-05, 1.06e-05, 0.0, 63.8434], // 785 nm
    [2.067383e-05, 7.4657e-06, 0.0, 64.304], // 790 nm
    [1.455977e-05, 5.2578e-06, 0.0, 61.8779], // 795 nm
    [1.025398e-05, 3.7029e-06, 0.0, 59.4519], // 800 nm
    [7.221456e-06, 2.6078e-06, 0.0, 55.7054], // 805 nm
    [5.085868e-06, 1.8366e-06, 0.0, 51.959], // 810 nm
    [3.581652e-06, 1.2934e-06, 0.0, 54.6998], // 815 nm
    [2.522525e-06, 9.1093e-07, 0.0, 57.4406], // 820 nm
    [1.776509e-06, 6.4153e-07, 0.0, 58.8765], // 825 nm
    [1.251141e-06, 4.5181e-07, 0.0, 60.3125], // 830 nm
];

/// The table linearly interpolated at `l` nm (zero outside it): (x̄, ȳ, z̄) and D65 / [`D65_SCALE`].
fn cie_at(l: f64) -> (DVec3, f64) {
    if !(CIE_MIN..=CIE_MAX).contains(&l) {
        return (DVec3::ZERO, 0.0);
    }
    let x = (l - CIE_MIN) / CIE_STEP;
    let i = (x.floor() as usize).min(CIE.len() - 2);
    let t = x - i as f64;
    let lerp = |k: usize| (1.0 - t) * CIE[i][k] + t * CIE[i + 1][k];
    (DVec3::new(lerp(0), lerp(1), lerp(2)), lerp(3) / D65_SCALE)
}

/// CIE XYZ to linear sRGB (IEC 61966-2-1; the digits Mitsuba uses), columns as glam stores them.
const XYZ_TO_SRGB: DMat3 = DMat3::from_cols_array(&[
    3.240479, -0.969256, 0.055648, //
    -1.537150, 1.875991, -0.204043, //
    -0.498535, 0.041556, 1.057311,
]);

/// The linear sRGB colour of a spectrum given as (wavelength in nm, value) samples in increasing
/// wavelength; `bounded`: a reflectance (D65-weighted, clamped to [0, 1]), else an emission or other
/// unbounded quantity (clamped to >= 0). The module's docs give the rule.
pub(super) fn spectrum_to_rgb(samples: &[(f64, f64)], bounded: bool) -> DVec3 {
    const STEPS: usize = 1000;
    let dl = (CIE_MAX - CIE_MIN) / STEPS as f64;
    let (first, last) = match samples {
        [f, .., l] => (f.0, l.0),
        _ => return DVec3::ZERO, // the reader asks for two samples at least
    };
    let mut xyz = DVec3::ZERO;
    let mut y_sum = 0.0;
    for i in 0..STEPS {
        let l = CIE_MIN + i as f64 / (STEPS - 1) as f64 * (CIE_MAX - CIE_MIN);
        let (cmf, d65) = cie_at(l);
        y_sum += cmf.y * dl;
        if l < first || l > last {
            continue;
        }
        // The interval [l0, l1] holding l (the last one when l is the last sample).
        let k = samples
            .partition_point(|s| s.0 <= l)
            .clamp(1, samples.len() - 1);
        let ((l0, v0), (l1, v1)) = (samples[k - 1], samples[k]);
        let v = if l1 > l0 {
            v0 + (v1 - v0) * (l - l0) / (l1 - l0)
        } else {
            v0
        };
        xyz += cmf * v * if bounded { d65 } else { 1.0 } * dl;
    }
    let rgb = XYZ_TO_SRGB * (xyz / y_sum);
    if bounded {
        rgb.clamp(DVec3::ZERO, DVec3::ONE)
    } else {
        rgb.max(DVec3::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table's ȳ integrates to the CIE's 106.857 (its 1 nm table's sum): a check of the
    /// transcription, and its peak is 1 at 555 nm.
    #[test]
    fn the_tables_integrate_to_the_cie_constants() {
        let trapezoid: f64 = CIE
            .windows(2)
            .map(|w| 0.5 * (w[0][1] + w[1][1]) * CIE_STEP)
            .sum();
        assert!((trapezoid - 106.857).abs() < 0.05, "{trapezoid}");
        assert_eq!(CIE[39][1], 1.0);
        // D65 is 100 at 560 nm by definition.
        assert!((CIE[40][3] - 100.0).abs() < 1e-9);
    }

    /// A flat spectrum: as an emission its luminance (sRGB's Y row) is its value; as a reflectance it is
    /// grey, D65 being sRGB's white, at the value times sum(ȳ D65) / sum(ȳ).
    #[test]
    fn flat_spectra_are_grey_reflectances_and_unit_luminance_emissions() {
        let flat = [(CIE_MIN, 2.0), (CIE_MAX, 2.0)];
        let e = spectrum_to_rgb(&flat, false);
        let y = 0.212671 * e.x + 0.715160 * e.y + 0.072169 * e.z;
        assert!((y - 2.0).abs() < 2e-5, "{e} (Y {y})");
        let half = [(CIE_MIN, 0.5), (CIE_MAX, 0.5)];
        let r = spectrum_to_rgb(&half, true);
        assert!((r.max_element() - r.min_element()) < 2e-3, "{r}");
        assert!((r.x - 0.5).abs() < 2e-3, "{r}");
        // Bounded: a reflectance of 3 is clamped to 1.
        assert_eq!(
            spectrum_to_rgb(&[(400.0, 3.0), (700.0, 3.0)], true),
            DVec3::ONE
        );
    }

    /// A spike at 450 nm (blue, outside sRGB's gamut): red is clamped to 0, nothing negative.
    #[test]
    fn out_of_gamut_spectra_are_clamped() {
        let spike = [(440.0, 0.0), (450.0, 1.0), (460.0, 0.0)];
        let c = spectrum_to_rgb(&spike, false);
        assert!(c.min_element() >= 0.0 && c.z > c.y, "{c}");
        assert_eq!(spectrum_to_rgb(&[(500.0, 1.0)], true), DVec3::ZERO);
    }
}
