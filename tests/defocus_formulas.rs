//! The Ch. 5 formulas (`wedge_effects::defocus::formulas`) against numbers worked by hand from the
//! thesis's equations (5.2, 5.7–5.8, 5.18–5.19, 5.22–5.29) and against the limits of its Sec. 5.7
//! discussion: in focus or aperture 0 → `n_p = 1`; point light → `n_dir^c = n_p`;
//! `n_dir^f ≤ n_dir^c`; counts monotone in μ; the literal eq. 5.29 stops at `Ω_pix^max`, the
//! consistent mode shrinks every filter to a pixel and grows every count without bound.

use wedge::effects::defocus::formulas::{
    compose_term, direct_rate, filter_width_px, indirect_rate, lens_std, light_half_width, omega_defocus, omega_direct,
    omega_indirect, omega_mu, omega_u_max, pixel_rates, pixel_scale, primary_rate, primary_strata,
    secondary_per_primary, secondary_strata, separable, strata_cap, weighted_texture, LensShape, Mode, PixelStats,
    RateParams, ThinLens, FILTER_SHARPNESS, OMEGA_PIX_MAX,
};
use wedge::scene::Vec2;

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol * b.abs().max(1.0)
}

#[test]
fn circle_of_confusion_eq_5_2_matches_the_thesis_parametrisation() {
    // vfov 45°, 512 rows: the thesis's W = 256 px and S = f tan(22.5°) (half-size of the focal plane).
    let (a, f) = (0.05f32, 4.0f32);
    let lens = ThinLens::new(a, f, 45.0, 512);
    let (w, s) = (256.0f32, f * 22.5f32.to_radians().tan());
    assert!(close(lens.pixel_scale, 2.0 * 22.5f32.to_radians().tan() / 512.0, 1e-6));
    for z in [0.5f32, 2.0, 3.9, 4.0, 6.0, 40.0] {
        let thesis_r = (a * w / s) * (f / z - 1.0);
        assert!(
            close(lens.circle_of_confusion(z), thesis_r, 1e-5),
            "z = {z}: {} vs {thesis_r}",
            lens.circle_of_confusion(z)
        );
        // ℓ_p = S z/(W f).
        assert!(close(lens.pixel_length(z), s * z / (w * f), 1e-6));
    }
    // By hand at z = 2: aW/S = 0.05·256/1.656854 = 7.72548 px, (f/z − 1) = 1.
    assert!(close(lens.circle_of_confusion(2.0), 7.72548, 1e-5));
    // In focus: 0; behind the focal plane: negative (the statistics take |r|).
    assert_eq!(lens.circle_of_confusion(4.0), 0.0);
    assert!(lens.circle_of_confusion(8.0) < 0.0);
    // λ = ℓ_p (x + r u) (eq. 5.1): the lens edge at z = 2 moves the hit by r pixels' worth of metres.
    let off = lens.surface_offset([0.0, 0.0], [1.0, 0.0], 2.0);
    assert!(close(off[0], lens.pixel_length(2.0) * 7.72548, 1e-5) && off[1] == 0.0);
}

#[test]
fn aperture_zero_is_a_pinhole_at_every_depth() {
    let pinhole = ThinLens::new(0.0, 0.0, 45.0, 480);
    for z in [1e-3f32, 0.5, 1.0, 7.0, 1e6] {
        assert_eq!(pinhole.circle_of_confusion(z), 0.0);
    }
    // r_min = r_max = 0 → Ω_x^d = Ω_pix^max and n_p = (2 Ω_pix^max)² = 1 (Sec. 5.7 discussion).
    let d = omega_defocus(0.0, OMEGA_PIX_MAX);
    assert_eq!(d, 0.5);
    assert_eq!(primary_rate(d, 0.0, OMEGA_PIX_MAX), 1.0);
    assert_eq!(primary_strata(primary_rate(d, 0.0, OMEGA_PIX_MAX), 8), 1);
}

#[test]
fn lens_shapes_weights_and_spread() {
    assert_eq!(LensShape::parse("disk"), Some(LensShape::Disk));
    assert_eq!(LensShape::parse("gaussian"), Some(LensShape::Gaussian));
    assert_eq!(LensShape::parse("box"), None);
    // Gaussian σ = 1 over u ∈ [−1, 1]: exp(−|u|²/2) (the sampler keeps u on the unit disk).
    assert_eq!(LensShape::Disk.weight(Vec2::new(0.6, 0.6)), 1.0);
    assert!(close(LensShape::Gaussian.weight(Vec2::new(1.0, 0.0)), (-0.5f32).exp(), 1e-7));
    assert!(close(LensShape::Gaussian.weight(Vec2::new(0.3, 0.4)), (-0.125f32).exp(), 1e-7));
    // The documented per-axis standard deviations, by midpoint quadrature over the disk.
    for shape in [LensShape::Disk, LensShape::Gaussian] {
        let n = 2000;
        let (mut w_sum, mut x2_sum) = (0f64, 0f64);
        for iy in 0..n {
            for ix in 0..n {
                let u = Vec2::new((ix as f32 + 0.5) / n as f32 * 2.0 - 1.0, (iy as f32 + 0.5) / n as f32 * 2.0 - 1.0);
                let w = if u.length_squared() <= 1.0 { shape.weight(u) as f64 } else { 0.0 };
                w_sum += w;
                x2_sum += w * (u.x as f64).powi(2);
            }
        }
        let std = (x2_sum / w_sum).sqrt() as f32;
        assert!(close(std, lens_std(shape), 2e-3), "{shape:?}: {std} vs {}", lens_std(shape));
        assert_eq!(omega_u_max(shape), 1.0);
    }
    // Within 5% of each other: the reason one Ω_u^max serves both.
    assert!((lens_std(LensShape::Gaussian) / lens_std(LensShape::Disk) - 1.0).abs() < 0.05);
}

#[test]
fn widths_eqs_5_7_5_18_5_22_by_hand() {
    // Defocus: r_min = 4 → min(0.5, 1/4) = 0.25, R = 1/Ω = r_min (eq. 5.8); r_min = 1 → pixel limit, R = 2.
    assert_eq!(omega_defocus(4.0, 0.5), 0.25);
    assert_eq!(filter_width_px(omega_defocus(4.0, 0.5)), 4.0);
    assert_eq!(omega_defocus(1.0, 0.5), 0.5);
    assert_eq!(filter_width_px(omega_defocus(1.0, 0.5)), 2.0);
    assert_eq!(omega_defocus(-4.0, 0.5), 0.25, "|r| is used");
    // Direct: ℓ_p = 0.01, ℓ_I = 0.1, s_min = 0.5: ℓ_p Ω_y^max / s_min = 0.01/(0.1·0.5) = 0.2;
    // R = ℓ_I s_min/ℓ_p = 5 px (eq. 5.19).
    let s = omega_direct(0.0, 0.5, 0.01, 0.1, 0.5);
    assert!(close(s, 0.2, 1e-6), "{s}");
    assert!(close(filter_width_px(s), 5.0, 1e-5));
    // The defocus term wins when smaller: r_min = 10 → 0.1.
    assert!(close(omega_direct(10.0, 0.5, 0.01, 0.1, 0.5), 0.1, 1e-6));
    // Point light or no occluder: no light term, Ω_x^s = Ω_x^d.
    assert_eq!(omega_direct(4.0, 0.5, 0.01, 0.0, 0.5), 0.25);
    assert_eq!(omega_direct(4.0, 0.0, 0.01, 0.1, 0.5), 0.25);
    // Indirect: ℓ_p Ω_v / z_min = 0.01·2.8/0.1 = 0.28; R = z_min/(ℓ_p Ω_v) = 3.5714 (eq. 5.23).
    let i = omega_indirect(0.0, 0.1, 0.01, 2.8, 0.5);
    assert!(close(i, 0.28, 1e-6), "{i}");
    assert!(close(filter_width_px(i), 3.571_428_5, 1e-5));
    assert_eq!(omega_indirect(0.0, 0.0, 0.01, 2.8, 0.5), 0.5, "no reflector: pixel limit");
    // Ω_x^s ≤ Ω_x^d ≤ Ω_pix^max (Sec. 5.7 discussion) on a grid.
    for r in [0.0f32, 0.5, 2.0, 9.0] {
        for sm in [0.0f32, 0.1, 1.0, 5.0] {
            let (d, s) = (omega_defocus(r, 0.5), omega_direct(r, sm, 0.01, 0.1, 0.5));
            assert!(s <= d && d <= 0.5);
        }
    }
}

#[test]
fn rates_eqs_5_24_to_5_28_by_hand() {
    // n_p = (0.5 + 0.25)² (1 + 8·0.25)² = 0.5625·9 = 5.0625 → p = ceil(2.25) = 3 → 9 rays.
    let n_p = primary_rate(0.25, 8.0, 0.5);
    assert!(close(n_p, 5.0625, 1e-6));
    assert_eq!(primary_strata(n_p, 64), 3);
    // n_dir^f = (0.5 + 0.2)² (1 + 0)² (1 + 0.1·2·0.2/0.01)² = 0.49·25 = 12.25 → s = ceil(3.5) = 4.
    let n_f = direct_rate(0.2, 0.0, 2.0, 0.01, 0.1, 0.5);
    assert!(close(n_f, 12.25, 1e-5), "{n_f}");
    assert_eq!(secondary_strata(n_f, 1, 64), 4);
    // n_dir^c at Ω_x^d = 0.5: 1·1·(1 + 0.1·2·0.5/0.01)² = 11² = 121 → s = 11 exactly (no extra stratum).
    let n_c = direct_rate(0.5, 0.0, 2.0, 0.01, 0.1, 0.5);
    assert!(close(n_c, 121.0, 1e-5), "{n_c}");
    assert_eq!(secondary_strata(n_c, 1, 64), 11);
    // n_ind^f = (0.78)² (2.8 + 0.5·0.28/0.01)² = 0.6084·16.8² = 171.714.
    let n_i = indirect_rate(0.28, 0.0, 0.5, 0.01, 2.8, 0.5);
    assert!(close(n_i, 171.714_24, 1e-5), "{n_i}");
    // With 9 primary rays (p = 3), 121 shadow rays need s = ceil(sqrt(121/9)) = ceil(3.667) = 4: 144.
    assert_eq!(secondary_strata(121.0, 3, 64), 4);
    // No reflector: the Ω_v term alone, 2.8² = 7.84 samples in focus.
    assert!(close(indirect_rate(0.5, 0.0, 0.0, 0.01, 2.8, 0.5), 7.84, 1e-6));
}

fn params(mu: f32, mode: Mode) -> RateParams {
    RateParams {
        mu,
        mode,
        omega_pix: OMEGA_PIX_MAX,
        // ℓ_p = 0.01 at depth 2.
        pixel_scale: 0.005,
        light_half_width: 0.1,
        omega_v: 2.8,
        max_primary: 4096,
        max_primary_moving: 4096,
        max_per_primary: 4096,
        max_shadow_per_primary: 4096,
        environment_per_primary: 4.0,
        width_pixel_limit: true,
    }
}

fn stats(r_min: f32, r_max: f32) -> PixelStats {
    PixelStats {
        r_min,
        r_max,
        depth: 2.0,
        hit: true,
        s_min: 0.5,
        s_max: 2.0,
        z_min: 0.1,
        z_max: 0.5,
        bandlimit: 0.0,
        v_p: 0.0,
        v_s: 0.0,
    }
}

#[test]
fn pixel_rates_by_hand_and_caps() {
    let r = pixel_rates(&stats(0.0, 0.0), &params(1.0, Mode::Literal));
    assert!(close(r.pixel_length, 0.01, 1e-6));
    assert_eq!(r.omega_defocus, 0.5);
    assert!(close(r.omega_direct, 0.2, 1e-6));
    assert!(close(r.omega_indirect, 0.28, 1e-6));
    assert_eq!(r.n_primary, 1);
    assert_eq!(r.n_direct_factored, 16); // 12.25 → 4²
    assert_eq!(r.n_direct_combined, 121); // 121 → 11²
    assert_eq!(r.n_indirect_factored, 196); // 171.7 → 14²
    assert_eq!(r.n_indirect_combined, 784); // (2.8 + 25)² = 772.84 → 28²
                                            // Caps round down to squares: 64 per primary → s ≤ 8; 10 primaries → p ≤ 3.
    let capped =
        RateParams { max_per_primary: 64, max_shadow_per_primary: 64, max_primary: 10, ..params(1.0, Mode::Literal) };
    let r = pixel_rates(&stats(0.0, 0.0), &capped);
    assert_eq!((r.n_direct_combined, r.n_indirect_factored, r.n_indirect_combined), (64, 64, 64));
    // The shadow rays have their own cap: 16 per primary caps direct light alone.
    let r = pixel_rates(&stats(0.0, 0.0), &RateParams { max_shadow_per_primary: 16, ..capped });
    assert_eq!((r.n_direct_combined, r.n_indirect_factored, r.n_indirect_combined), (16, 64, 64));
    // r_min = 1, r_max = 500: n_p = 1·(1 + 250)² → p = 251, capped at 3.
    let r = pixel_rates(&stats(1.0, 500.0), &capped);
    assert_eq!(r.n_primary, 9);
    assert_eq!(strata_cap(10), 3);
    assert_eq!(strata_cap(9), 3);
    assert_eq!(strata_cap(0), 1);
    // A missed pixel: one ray of each kind, pixel-limit widths.
    let miss = pixel_rates(&PixelStats::default(), &params(1.0, Mode::Literal));
    assert_eq!((miss.n_primary, miss.n_direct_combined, miss.n_indirect_factored), (1, 1, 1));
    assert_eq!(miss.omega_defocus, 0.5);
    // Non-finite statistics take the caps, never a NaN count.
    let bad = pixel_rates(&stats(0.0, f32::INFINITY), &params(1.0, Mode::Literal));
    assert_eq!(bad.n_primary, 64 * 64);
    let nan = pixel_rates(&stats(f32::NAN, f32::NAN), &params(1.0, Mode::Literal));
    assert!(nan.n_primary >= 1 && nan.omega_defocus == 0.5);
}

#[test]
fn in_focus_gives_one_primary_ray() {
    for mode in [Mode::Literal, Mode::Consistent] {
        for (s_min, z_min) in [(0.0, 0.0), (0.5, 0.1), (3.0, 2.0)] {
            let s = PixelStats { s_min, z_min, ..stats(0.0, 0.0) };
            assert_eq!(pixel_rates(&s, &params(1.0, mode)).n_primary, 1);
        }
    }
    // Literal (5.29) keeps n_p = 1 in focus for every μ.
    for mu in [0.5f32, 1.0, 2.0, 8.0, 1e3, 1e6] {
        assert_eq!(pixel_rates(&stats(0.0, 0.0), &params(mu, Mode::Literal)).n_primary, 1, "μ = {mu}");
    }
}

#[test]
fn point_light_gives_one_shadow_ray_per_primary_ray() {
    // ℓ_I = 0: n_dir^c = n_p (Sec. 5.7 discussion), unrounded and rounded.
    for mode in [Mode::Literal, Mode::Consistent] {
        for mu in [0.5f32, 1.0, 3.0] {
            for (r_min, r_max) in [(0.0, 0.0), (1.0, 3.0), (4.0, 20.0)] {
                let k = RateParams { light_half_width: 0.0, ..params(mu, mode) };
                let d = omega_mu(omega_defocus(r_min, 0.5), mu, mode, 0.5);
                assert_eq!(direct_rate(d, r_max, 2.0, 0.01, 0.0, 0.5), primary_rate(d, r_max, 0.5));
                let r = pixel_rates(&stats(r_min, r_max), &k);
                assert_eq!(r.n_direct_combined, r.n_primary, "{mode:?} μ = {mu} r = {r_min}..{r_max}");
                assert_eq!(r.n_direct_factored, r.n_primary);
            }
        }
    }
}

/// A deterministic grid of statistics covering focus, defocus, near and far occluders and reflectors.
fn stat_grid() -> Vec<PixelStats> {
    let mut v = Vec::new();
    for (r_min, r_max) in [(0.0, 0.0), (0.0, 2.0), (1.5, 4.0), (6.0, 25.0)] {
        for (s_min, s_max) in [(0.0, 0.0), (0.05, 0.5), (0.5, 4.0)] {
            for (z_min, z_max) in [(0.0, 0.0), (0.05, 0.3), (1.0, 5.0)] {
                for depth in [0.5f32, 2.0, 10.0] {
                    for bandlimit in [0.0f32, 0.5, 20.0] {
                        v.push(PixelStats {
                            r_min,
                            r_max,
                            depth,
                            hit: true,
                            s_min,
                            s_max,
                            z_min,
                            z_max,
                            bandlimit,
                            v_p: 0.0,
                            v_s: 0.0,
                        });
                    }
                }
            }
        }
    }
    v
}

#[test]
fn factored_never_needs_more_rays_than_combined() {
    for mode in [Mode::Literal, Mode::Consistent] {
        for mu in [0.25f32, 1.0, 2.0, 6.0] {
            for s in stat_grid() {
                let r = pixel_rates(&s, &params(mu, mode));
                assert!(r.n_direct_factored <= r.n_direct_combined, "{s:?} {mode:?} μ = {mu}: {r:?}");
                assert!(r.n_indirect_factored <= r.n_indirect_combined, "{s:?} {mode:?} μ = {mu}: {r:?}");
                assert!(r.n_environment_factored <= r.n_environment_combined, "{s:?} {mode:?} μ = {mu}: {r:?}");
                assert!(r.omega_direct <= r.omega_defocus && r.omega_indirect <= r.omega_defocus);
                assert!(r.omega_environment <= r.omega_defocus);
                // At least one secondary ray per primary ray, and whole strata (p² s²).
                for n in [
                    r.n_direct_factored,
                    r.n_direct_combined,
                    r.n_indirect_factored,
                    r.n_indirect_combined,
                    r.n_environment_factored,
                    r.n_environment_combined,
                ] {
                    assert!(n >= r.n_primary && n % r.n_primary == 0);
                    let q = n / r.n_primary;
                    assert_eq!(((q as f64).sqrt().round() as u32).pow(2), q, "{q} is not a square");
                }
            }
        }
    }
}

/// The unrounded rates of eqs. 5.24–5.28 at a pixel's (μ-scaled) widths.
fn unrounded(s: &PixelStats, r: &wedge::effects::defocus::formulas::PixelRates, k: &RateParams) -> [f32; 5] {
    let l = r.pixel_length;
    [
        primary_rate(r.omega_defocus, s.r_max, k.omega_pix),
        direct_rate(r.omega_direct, s.r_max, s.s_max, l, k.light_half_width, k.omega_pix),
        direct_rate(r.omega_defocus, s.r_max, s.s_max, l, k.light_half_width, k.omega_pix),
        indirect_rate(r.omega_indirect, s.r_max, s.z_max, l, k.omega_v, k.omega_pix),
        indirect_rate(r.omega_defocus, s.r_max, s.z_max, l, k.omega_v, k.omega_pix),
    ]
}

#[test]
fn counts_are_monotone_in_mu() {
    // The rates (eqs. 5.24–5.29) and the primary strata p grow with μ. The secondary totals p² s²
    // are the smallest (multiple of p)² ≥ n, which is not monotone when p itself steps up (e.g.
    // √n = 6.5: p = 3 → 81, p = 4 → 64), so for them the test checks that they cover the rate.
    let mus = [0.1f32, 0.25, 0.5, 1.0, 1.5, 2.0, 4.0, 8.0, 16.0];
    for mode in [Mode::Literal, Mode::Consistent] {
        for s in stat_grid() {
            let k0 = params(mus[0], mode);
            let mut last = pixel_rates(&s, &k0);
            let mut last_n = unrounded(&s, &last, &k0);
            for &mu in &mus[1..] {
                let k = params(mu, mode);
                let r = pixel_rates(&s, &k);
                let n = unrounded(&s, &r, &k);
                assert!(last.n_primary <= r.n_primary, "{s:?} {mode:?} μ = {mu}: {last:?} → {r:?}");
                for c in 0..5 {
                    assert!(last_n[c] <= n[c], "{s:?} {mode:?} μ = {mu}: rate {c} {} → {}", last_n[c], n[c]);
                }
                // Widths (bandlimits) grow too: filters narrow as μ grows.
                assert!(last.omega_defocus <= r.omega_defocus && last.omega_direct <= r.omega_direct);
                assert!(last.omega_indirect <= r.omega_indirect);
                // Rounded counts cover their rates wherever no cap binds.
                let rounded = [
                    r.n_primary,
                    r.n_direct_factored,
                    r.n_direct_combined,
                    r.n_indirect_factored,
                    r.n_indirect_combined,
                ];
                let p = (r.n_primary as f64).sqrt() as u32;
                for c in 0..5 {
                    let q = rounded[c] / r.n_primary;
                    if p < 64 && q < 64 * 64 {
                        assert!(rounded[c] as f32 >= n[c] * (1.0 - 1e-3), "{s:?} μ = {mu}: {} < {}", rounded[c], n[c]);
                    }
                }
                last = r;
                last_n = n;
            }
        }
    }
}

#[test]
fn modes_agree_for_mu_up_to_one() {
    for mu in [0.1f32, 0.5, 0.9, 1.0] {
        for s in stat_grid() {
            assert_eq!(pixel_rates(&s, &params(mu, Mode::Literal)), pixel_rates(&s, &params(mu, Mode::Consistent)));
        }
    }
}

#[test]
fn literal_mode_stops_consistent_mode_converges() {
    let s = stats(3.0, 12.0);
    // Literal: every width is clamped at Ω_pix^max for μ ≥ 2.5 here, so filters and counts stop growing
    // (the nearest neighbour keeps weight e⁻⁴ in the defocus filter forever).
    let at = |mu: f32, mode| pixel_rates(&s, &params(mu, mode));
    let lit = at(1e3, Mode::Literal);
    assert_eq!(lit, at(1e6, Mode::Literal));
    assert_eq!((lit.omega_defocus, lit.omega_direct, lit.omega_indirect), (0.5, 0.5, 0.5));
    assert!(close((-FILTER_SHARPNESS * lit.omega_defocus * lit.omega_defocus).exp(), (-4.0f32).exp(), 1e-6));
    // Consistent: widths grow as μ Ω, so the neighbour weight exp(−16 Ω²) → 0 (a one-pixel filter)…
    let mut last_n = 0f32;
    for mu in [1.0f32, 10.0, 100.0, 1e3, 1e4] {
        let r = at(mu, Mode::Consistent);
        assert!(close(r.omega_defocus, mu * omega_defocus(3.0, 0.5), 1e-6));
        let n = primary_rate(r.omega_defocus, 12.0, 0.5);
        assert!(n > last_n);
        last_n = n;
    }
    let far = at(1e3, Mode::Consistent);
    assert_eq!((-FILTER_SHARPNESS * far.omega_defocus * far.omega_defocus).exp(), 0.0);
    assert_eq!((-FILTER_SHARPNESS * far.omega_direct * far.omega_direct).exp(), 0.0);
    // …and every count grows without bound (here up to the caps: 64² primaries, 64² per primary).
    assert!(last_n > 1e9);
    assert_eq!(far.n_primary, 4096);
    assert_eq!(far.n_direct_combined, 4096 * 4096);
    // In focus too: consistent mode supersamples the pixel as μ grows (anti-aliasing converges).
    assert_eq!(pixel_rates(&stats(0.0, 0.0), &params(2.0, Mode::Consistent)).n_primary, 4);
    // (0.5+1)² = 2.25 → 2²
}

#[test]
fn secondary_per_primary_after_the_max_filter() {
    assert_eq!(secondary_per_primary(4, 36), 9);
    assert_eq!(secondary_per_primary(4, 37), 16);
    assert_eq!(secondary_per_primary(9, 1), 1);
    assert_eq!(secondary_per_primary(0, 5), 9);
    assert_eq!(secondary_per_primary(1, 0), 1);
}

#[test]
fn supersampling_reading_omega_pix_quarter() {
    // docs/EQUATIONS.md reading: anti-aliasing by supersampling uses Ω_pix^max = 0.25; in focus
    // n_p = (0.25 + 0.25)² = 0.25 → still one ray.
    let k = RateParams { omega_pix: 0.25, ..params(1.0, Mode::Literal) };
    let r = pixel_rates(&stats(0.0, 0.0), &k);
    assert_eq!((r.omega_defocus, r.n_primary), (0.25, 1));
    assert_eq!(pixel_scale(90.0, 2), 1.0);
}

#[test]
fn factoring_flag_eq_5_30() {
    let k = [0.5, 0.25, 1.0];
    let e = [0.8, 0.4, 0.2];
    let ke = [0.4, 0.1, 0.2];
    assert!(separable(ke, k, e, 0.01));
    // ‖L − kE‖ = 0.009 → separable; 0.011 → not.
    assert!(separable([0.409, 0.1, 0.2], k, e, 0.01));
    assert!(!separable([0.411, 0.1, 0.2], k, e, 0.01));
    // Euclidean over RGB: 0.006 in each channel is 0.0104 > 0.01.
    assert!(!separable([0.406, 0.106, 0.206], k, e, 0.01));
    assert!(!separable([f32::NAN, 0.1, 0.2], k, e, 0.01));
    assert!(!separable([f32::INFINITY, 0.1, 0.2], k, e, 0.01));
}

#[test]
fn light_half_width_and_camera_lens() {
    use wedge::scene::{AreaLight, Camera, LightShape, Vec3};
    let rect = AreaLight {
        shape: LightShape::Rect {
            corner: Vec3::ZERO,
            edge_u: Vec3::new(0.6, 0.0, 0.0),
            edge_v: Vec3::new(0.0, 0.0, 0.2),
        },
        radiance: Vec3::ONE,
        two_sided: false,
    };
    // ℓ_I = half the longer side (0.3), not Ch. 3's 0.6/√12 = 0.173.
    assert!(close(light_half_width(&rect), 0.3, 1e-6));
    let tri = AreaLight {
        shape: LightShape::Triangle { v0: Vec3::ZERO, v1: Vec3::new(0.3, 0.0, 0.0), v2: Vec3::new(0.0, 0.4, 0.0) },
        radiance: Vec3::ONE,
        two_sided: false,
    };
    assert!(close(light_half_width(&tri), 0.25, 1e-6)); // hypotenuse 0.5
    let camera = Camera { aperture_radius: 0.05, focus_distance: 4.0, vfov_deg: 45.0, ..Camera::default() };
    assert_eq!(ThinLens::from_camera(&camera, 512), ThinLens::new(0.05, 4.0, 45.0, 512));
    // The path sampler's circle of confusion (Camera::coc_pixels) is the same eq. 5.2.
    for z in [0.5f32, 2.0, 4.0, 9.0] {
        let (ours, camera_r) = (ThinLens::from_camera(&camera, 512).circle_of_confusion(z), camera.coc_pixels(z, 512));
        assert!(close(ours, camera_r, 1e-5), "z = {z}: {ours} vs {camera_r}");
    }
    // Focus distance unset: focus at the look-at point (here 5 units away).
    let unset = Camera { position: Vec3::new(0.0, 3.0, 4.0), look_at: Vec3::ZERO, focus_distance: 0.0, ..camera };
    assert_eq!(ThinLens::from_camera(&unset, 512), ThinLens::new(0.05, 5.0, 45.0, 512));
}

#[test]
fn compose_term_eq_5_32() {
    let (l, k, e) = ([0.3, 0.2, 0.1], [0.5, 0.25, 1.0], [0.8, 0.4, 0.2]);
    assert_eq!(compose_term(l, k, e, true), [0.4, 0.1, 0.2]);
    assert_eq!(compose_term(l, k, e, false), l);
}

/// `L / Ē`: the paths' `k` weighted by the irradiance each brought. Two paths, a lit bright texel
/// (k 0.8, E 1) and a dim one in shadow (k 0.2, E 0): L = 0.4, Ē = 0.5, so the texture is 0.8 where
/// the paths' mean is 0.5. Where `k` is constant it is `k`; where Ē is 0 (or L / Ē not finite), `k`.
#[test]
fn the_weighted_texture_is_the_irradiance_weighted_mean_of_k() {
    assert_eq!(weighted_texture([0.4, 0.4, 0.4], [0.5; 3], [0.5; 3]), [0.8; 3]);
    assert_eq!(weighted_texture([0.25, 0.1, 0.0], [0.5, 0.25, 1.0], [0.5, 0.4, 0.0]), [0.5, 0.25, 1.0]);
    assert_eq!(weighted_texture([f32::INFINITY, 0.1, 0.1], [0.3; 3], [1.0, -1.0, f32::NAN]), [0.3; 3]);
}

/// Lens and shutter together (docs/DEFOCUS-MOTION.md DM.8, DM.11, DM.12): a still pixel keeps Ch. 5's
/// counts bit for bit; a moving primary hit adds `(1 + |v_p| Ω)²` to the primary and the combined
/// counts, a moving shadow `(1 + |v_s| Ω)²` to the direct ones; the factored indirect and environment
/// irradiance take no time factor (App. B's reading), and no width changes.
#[test]
fn the_shutter_adds_time_factors_to_the_counts_and_leaves_the_widths() {
    use wedge::effects::defocus::formulas::time_factor;
    for mode in [Mode::Literal, Mode::Consistent] {
        for s in stat_grid() {
            let k = params(1.0, mode);
            let still = pixel_rates(&s, &k);
            assert_eq!(pixel_rates(&PixelStats { v_p: 0.0, v_s: 0.0, ..s }, &k), still);
            let moving = pixel_rates(&PixelStats { v_p: 12.0, v_s: 5.0, ..s }, &k);
            let widths = |r: &wedge::effects::defocus::formulas::PixelRates| {
                [r.omega_defocus, r.omega_direct, r.omega_indirect, r.omega_environment, r.pixel_length]
            };
            assert_eq!(widths(&moving), widths(&still), "{s:?}");
            for (m, st) in [
                (moving.n_primary, still.n_primary),
                (moving.n_direct_factored, still.n_direct_factored),
                (moving.n_direct_combined, still.n_direct_combined),
                (moving.n_indirect_combined, still.n_indirect_combined),
                (moving.n_environment_combined, still.n_environment_combined),
            ] {
                assert!(m >= st, "{s:?}: {moving:?} vs {still:?}");
            }
            if s.hit && s.r_max == 0.0 && still.n_primary < 64 {
                // In focus, μ = 1: Ω_d = 0.5, so n_p = 1 · (1 + 12 · 0.5)² = 49 → 7².
                assert_eq!(moving.n_primary, 49, "{s:?}");
            }
        }
    }
    assert_eq!(time_factor(0.0, 0.37), 1.0);
    assert_eq!(time_factor(2.0, 0.5), 4.0);
}

/// The screen filter's width (eq. 5.33): with the pixel limit eq. 5.7's `Ω_x^d` as the counts take
/// it; without, the lens term alone — infinite (a pass-through) in focus, `μ Ω_u^max / r_min` beyond.
#[test]
fn the_screen_width_is_the_lens_term_alone_unless_pixel_limited() {
    use wedge::effects::defocus::formulas::{omega_defocus, screen_width, OMEGA_PIX_MAX};
    let d = omega_defocus(0.5, OMEGA_PIX_MAX);
    assert_eq!(screen_width(d, 0.5, 1.0, true), d);
    assert_eq!(d, OMEGA_PIX_MAX);
    assert_eq!(screen_width(d, 0.5, 1.0, false), 2.0);
    assert_eq!(screen_width(d, 0.0, 1.0, false), f32::INFINITY);
    // Out of focus (a 4-px circle of confusion) the two agree: the lens term is below the limit.
    let d = omega_defocus(4.0, OMEGA_PIX_MAX);
    assert_eq!(screen_width(d, 4.0, 1.0, false), d);
    // μ scales it without bound: the filter vanishes as μ → ∞.
    assert_eq!(screen_width(d, 4.0, 8.0, false), 2.0);
}

/// `max_primary_moving`: the still cap binds the lens's share, a moving pixel's cap grows with the
/// time factor's `1 + |v| Ω` per side up to the moving cap; at or below the still cap, the still cap
/// everywhere (the default: the bits of a pipeline that does not state it).
#[test]
fn a_moving_pixels_primary_cap_grows_with_its_time_factor() {
    use wedge::effects::defocus::formulas::primary_cap;
    assert_eq!(primary_cap(4, 16, 1.0), 4);
    assert_eq!(primary_cap(4, 16, 1.9), 7);
    assert_eq!(primary_cap(4, 16, 9.0), 16);
    assert_eq!(primary_cap(4, 16, f32::INFINITY), 16);
    assert_eq!(primary_cap(4, 4, 9.0), 4);
    assert_eq!(primary_cap(16, 4, 9.0), 16);
    // r_min = 1, r_max = 500 asks for 251² primaries; a still cap of 16 gives 4², a moving pixel
    // (|v| Ω = 1.1: 4 · 2.1 → 8 per side) 8², under a moving cap of 256.
    let k = RateParams { max_primary: 16, max_primary_moving: 256, ..params(1.0, Mode::Literal) };
    assert_eq!(pixel_rates(&stats(1.0, 500.0), &k).n_primary, 16);
    let d = omega_mu(omega_defocus(1.0, OMEGA_PIX_MAX), 1.0, Mode::Literal, OMEGA_PIX_MAX);
    let moving = PixelStats { v_p: 1.1 / d, ..stats(1.0, 500.0) };
    assert_eq!(pixel_rates(&moving, &k).n_primary, 64);
    // Absent (= max_primary), the moving pixel keeps the still cap.
    assert_eq!(pixel_rates(&moving, &RateParams { max_primary_moving: 16, ..k }).n_primary, 16);
}
