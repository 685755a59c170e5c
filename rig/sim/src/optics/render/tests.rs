//! Tests of [`super`] (in a file of their own: they use the crate's test helpers, which use
//! the renderer).

use super::*;
use crate::optics::background::pixel_light;
use crate::test_support::{contact, disc_pixels, grey, quiet, render, small};

/// Bilinear grey value at image position (u, v) px (pixel centres at + 0.5).
fn grey_at(img: &[u8], w: usize, u: f64, v: f64) -> f64 {
    let (x, y) = (u - 0.5, v - 0.5);
    let (i, j) = (x.floor() as usize, y.floor() as usize);
    let (fx, fy) = (x - i as f64, y - j as f64);
    let top = grey(img, w, i, j) * (1.0 - fx) + grey(img, w, i + 1, j) * fx;
    let bottom = grey(img, w, i, j + 1) * (1.0 - fx) + grey(img, w, i + 1, j + 1) * fx;
    top * (1.0 - fy) + bottom * fy
}

#[test]
fn zero_force_gives_exactly_the_unloaded_background() {
    let mut r = Renderer::new(small(SensorConfig::layered())).expect("renderer");
    // Compute every lit pixel (not only those within the contact's reach).
    r.skip_below = 0.0;
    let empty = render(&mut r, None, 17);
    let shape = r.config().rectangle();
    let zero = render(&mut r, Some(contact(shape, 0.0, 5.0, 3.0, 20.0)), 17);
    assert!(empty == zero, "a contact with 0 N changed the frame");
    let loaded = render(&mut r, Some(contact(shape, 4.0, 5.0, 3.0, 20.0)), 17);
    let changed = empty.iter().zip(&loaded).filter(|(a, b)| a != b).count();
    assert!(changed > 1000, "4 N changed only {changed} bytes");
    // Same frame index, same bytes (noise included); another frame has other noise.
    assert!(render(&mut r, None, 17) == empty);
    assert!(render(&mut r, None, 18) != empty);
}

#[test]
fn bayer_and_mono_frames_are_the_samples_of_the_rgb_frame() {
    let mut r = Renderer::new(small(SensorConfig::layered())).expect("renderer");
    let pressed = Some(contact(r.config().pentagon(), 6.0, 4.0, -3.0, 15.0));
    for (scene, frame) in [(pressed, 5), (None, 6)] {
        let rgb = render(&mut r, scene, frame);
        for format in [PixelFormat::BayerRg8, PixelFormat::Mono8] {
            let mut native = Vec::new();
            r.render_as(&Scene { contact: scene }, frame, format, &mut native);
            let mut sampled = Vec::new();
            crate::optics::pixel_format::from_rgb(&rgb, r.width() as usize, format, &mut sampled);
            assert_eq!(native.len(), (r.width() * r.height()) as usize);
            assert!(
                native == sampled,
                "{format:?} is not the {format:?} of the RGB frame"
            );
        }
    }
}

#[test]
fn fringe_order_is_linear_in_force_for_a_flat_punch() {
    let mut c = quiet(SensorConfig::integrated());
    c.optics.blur_px = 0.0;
    let mut r = Renderer::new(c).expect("renderer");
    let shape = r.config().pentagon();
    let one = r.fringe_order_map(&contact(shape, 1.5, -4.0, 6.0, 33.0));
    let three = r.fringe_order_map(&contact(shape, 4.5, -4.0, 6.0, 33.0));
    let peak = one.iter().copied().fold(0.0f32, f32::max);
    assert!(peak > 0.3, "peak order at 1.5 N {peak}");
    for (a, b) in one.iter().zip(&three) {
        assert!((3.0 * a - b).abs() <= 1e-5 * b.abs().max(1e-3), "{a} {b}");
    }
    // The rendered colours are the colour table at those orders: a pixel's grey level follows
    // the sharp table at F N_unit + residual (the spread there is small).
    let img = render(&mut r, Some(contact(shape, 4.5, -4.0, 6.0, 33.0)), 0);
    let w = r.width() as usize;
    let mut diffs = Vec::new();
    for (i, j) in disc_pixels(&r, 0.8) {
        let k = j * w + i;
        let order = three[k] + r.background.residual(k);
        let rgb = r.colours.lookup(order, 0.0);
        let light = pixel_light(r.background.illumination(k), rgb, r.background.glow(k));
        let expected = (light[0] + light[1] + light[2]) / 3.0;
        diffs.push((grey(&img, w, i, j) - f64::from(expected)).abs());
    }
    diffs.sort_by(f64::total_cmp);
    let median = diffs[diffs.len() / 2];
    eprintln!(
        "median |rendered - table colour| {median} DN, peak order {}",
        3.0 * peak
    );
    assert!(median < 1.0, "{median}");
}

#[test]
fn rotating_the_contact_about_the_optical_centre_rotates_the_image() {
    for variant in [SensorConfig::layered(), SensorConfig::integrated()] {
        let mut c = quiet(variant);
        c.leds.count = 0;
        c.optics.residual_birefringence = 0.0;
        let mut r = Renderer::new(c).expect("renderer");
        let g = r.geometry();
        let shape = r.config().rectangle();
        let (x, y, angle, theta) = (8.0f64, 3.0f64, 10.0f64, 40.0f64);
        let (s, co) = theta.to_radians().sin_cos();
        let a = render(&mut r, Some(contact(shape, 6.0, x, y, angle)), 0);
        let (xr, yr) = (co * x - s * y, s * x + co * y);
        let b = render(&mut r, Some(contact(shape, 6.0, xr, yr, angle + theta)), 0);
        let w = r.width() as usize;
        let (mut diff, mut base, mut count) = (0.0, 0.0, 0.0);
        for (i, j) in disc_pixels(&r, 0.85) {
            // The point seen at pixel (i, j) in b was, before the rotation, at ...
            let [sx, sy] = g.to_sensor(i as f64 + 0.5, j as f64 + 0.5);
            let [u, v] = g.to_pixel(co * sx + s * sy, -s * sx + co * sy);
            diff += (grey(&b, w, i, j) - grey_at(&a, w, u, v)).abs();
            base += (grey(&b, w, i, j) - grey(&a, w, i, j)).abs();
            count += 1.0;
        }
        let (diff, base) = (diff / count, base / count);
        eprintln!(
            "{}: rotated vs image rotated {diff} DN, unrotated {base} DN",
            r.config().id
        );
        // Half-resolution sampling (2x2 blocks) is not rotation invariant: its error counts
        // as interpolation error here.
        assert!(diff < 0.2 * base && diff < 4.0, "{diff} vs {base}");
    }
}

#[test]
fn mirror_flag_mirrors_the_image_about_the_optical_centre() {
    let mut c = quiet(SensorConfig::layered());
    c.geometry.mirror = false;
    let mut plain = Renderer::new(c.clone()).expect("renderer");
    c.geometry.mirror = true;
    let mut mirrored = Renderer::new(c).expect("renderer");
    let scene = Some(contact(plain.config().pentagon(), 7.0, 9.0, -5.0, 12.0));
    let a = render(&mut plain, scene, 3);
    let b = render(&mut mirrored, scene, 3);
    let w = plain.width() as usize;
    let cu = plain.geometry().centre_px[0];
    let (mut diff, mut base, mut count) = (0.0, 0.0, 0.0);
    for (i, j) in disc_pixels(&plain, 1.05) {
        let im = (2.0 * cu - 1.0 - i as f64).round() as usize;
        diff += (grey(&b, w, i, j) - grey(&a, w, im, j)).abs();
        base += (grey(&b, w, i, j) - grey(&a, w, i, j)).abs();
        count += 1.0;
    }
    let (diff, base) = (diff / count, base / count);
    eprintln!("mirrored vs flipped {diff} DN, vs unflipped {base} DN");
    assert!(diff < 0.05 && base > 2.0, "{diff} {base}");
}

#[test]
fn contact_appears_where_the_geometry_puts_it() {
    let mut c = quiet(SensorConfig::integrated());
    c.layer.bottom_mm = 1.0; // fringes close to the contact
    c.geometry.rotation_deg = 63.0;
    let mut r = Renderer::new(c).expect("renderer");
    let empty = render(&mut r, None, 0);
    let shape = r.config().rectangle();
    let w = r.width() as usize;
    for &(x, y) in &[(7.0, -4.0), (-10.0, 7.0)] {
        let img = render(&mut r, Some(contact(shape, 6.0, x, y, 25.0)), 0);
        let (mut su, mut sv, mut total) = (0.0, 0.0, 0.0);
        for j in 0..r.height() as usize {
            for i in 0..w {
                // Change per unit of light (vignetting would pull the centroid towards the
                // centre), squared: the strong fringes near the punch outweigh the far
                // field that the disc edge cuts off.
                let light = f64::from(r.background.illumination(j * w + i));
                if light < 1.0 {
                    continue;
                }
                let e = ((grey(&img, w, i, j) - grey(&empty, w, i, j)) / light).powi(2);
                su += e * (i as f64 + 0.5);
                sv += e * (j as f64 + 0.5);
                total += e;
            }
        }
        let [pu, pv] = r.geometry().to_pixel(x, y);
        let (cu, cv) = (su / total, sv / total);
        eprintln!("contact ({x}, {y}) mm: fringe centroid ({cu}, {cv}), predicted ({pu}, {pv})");
        assert!(
            (cu - pu).hypot(cv - pv) < 1.5,
            "({cu}, {cv}) vs ({pu}, {pv})"
        );
    }
}

#[test]
fn led_hot_spots_lie_just_outside_the_disc() {
    // Larger than the other tests' images: hot spots sit 2 % of the radius outside the disc.
    let mut c = quiet(SensorConfig::layered());
    c.geometry.width = 640;
    c.geometry.height = 400;
    c.geometry.disc_radius_px = 180.0;
    c.geometry.px_per_mm = 6.0;
    c.leds.width_px = 12.0;
    c.field.cells = 32;
    c.field.cell_mm = 2.0;
    c.optics.residual_birefringence = 0.0;
    c.leds.count = 10;
    let mut r = Renderer::new(c).expect("renderer");
    let img = render(&mut r, None, 0);
    let w = r.width() as usize;
    let g = r.geometry();
    let radius = r.config().geometry.disc_radius_px;
    let radius_of = |i: usize, j: usize| {
        (i as f64 + 0.5 - g.centre_px[0]).hypot(j as f64 + 0.5 - g.centre_px[1])
    };
    let max = (0..img.len() / 3)
        .map(|k| grey(&img, w, k % w, k / w))
        .fold(0.0, f64::max);
    // The brightest pixel of each of ten sectors (one LED each) lies beyond the disc edge.
    let mut sector_max = [(0.0f64, 0.0f64); 10];
    for j in 0..r.height() as usize {
        for i in 0..w {
            let (du, dv) = (
                i as f64 + 0.5 - g.centre_px[0],
                j as f64 + 0.5 - g.centre_px[1],
            );
            let turn = (dv.atan2(du) / std::f64::consts::TAU).rem_euclid(1.0);
            let sector = ((turn * 10.0) as usize).min(9);
            let v = grey(&img, w, i, j);
            if v > sector_max[sector].0 {
                sector_max[sector] = (v, radius_of(i, j) / radius);
            }
        }
    }
    eprintln!("sector maxima (DN, radius / R): {sector_max:?}");
    for (v, at) in sector_max {
        assert!(v > 0.6 * max && at > 1.0 && at < 1.06, "{v} DN at {at} R");
    }
    // Ten separate peaks around the ring at 1.02 R.
    let ring: Vec<f64> = (0..720)
        .map(|k| {
            let a = (k as f64 / 2.0).to_radians();
            let rr = 1.02 * radius;
            grey_at(
                &img,
                w,
                g.centre_px[0] + rr * a.cos(),
                g.centre_px[1] + rr * a.sin(),
            )
        })
        .collect();
    let mid = 0.5 * (ring.iter().copied().fold(f64::MAX, f64::min) + max);
    let rises = (0..720)
        .filter(|&k| ring[k] > mid && ring[(k + 719) % 720] <= mid)
        .count();
    assert_eq!(rises, 10);
}

#[test]
fn blur_reduces_high_frequency_energy() {
    let energy = |blur: f64| {
        let mut c = quiet(SensorConfig::layered());
        c.optics.residual_birefringence = 0.0;
        c.optics.blur_px = blur;
        let mut r = Renderer::new(c).expect("renderer");
        let shape = r.config().pentagon();
        let img = render(&mut r, Some(contact(shape, 9.0, 2.0, 1.0, 0.0)), 0);
        let w = r.width() as usize;
        let lap = |i: usize, j: usize| {
            4.0 * grey(&img, w, i, j)
                - grey(&img, w, i - 1, j)
                - grey(&img, w, i + 1, j)
                - grey(&img, w, i, j - 1)
                - grey(&img, w, i, j + 1)
        };
        let inner: f64 = disc_pixels(&r, 0.8)
            .iter()
            .map(|&(i, j)| lap(i, j).powi(2))
            .sum();
        // The disc edge and hot spots: an annulus 0.9..1.07 R.
        let all: f64 = disc_pixels(&r, 1.07)
            .iter()
            .map(|&(i, j)| lap(i, j).powi(2))
            .sum();
        let outer = all
            - disc_pixels(&r, 0.9)
                .iter()
                .map(|&(i, j)| lap(i, j).powi(2))
                .sum::<f64>();
        (inner, outer)
    };
    let (sharp_in, sharp_rim) = energy(0.0);
    let (blur_in, blur_rim) = energy(6.0);
    eprintln!("Laplacian energy: fringes {sharp_in} -> {blur_in}, rim {sharp_rim} -> {blur_rim}");
    assert!(blur_in < 0.3 * sharp_in, "{blur_in} vs {sharp_in}");
    assert!(blur_rim < 0.5 * sharp_rim, "{blur_rim} vs {sharp_rim}");
}

#[test]
fn spheres_grow_with_force_and_reuse_cached_fields() {
    let mut r = Renderer::new(quiet(SensorConfig::layered())).expect("renderer");
    let fields_before = r.fields.len();
    let area = |r: &mut Renderer, force: f64| {
        let shape = r.config().sphere(force);
        let map = r.fringe_order_map(&contact(shape, force, 0.0, 0.0, 0.0));
        map.iter().filter(|&&n| n > 0.5).count()
    };
    let (small, large) = (area(&mut r, 1.0), area(&mut r, 9.0));
    assert!(large > small, "{small} {large}");
    assert_eq!(r.fields.len(), fields_before + 2);
    area(&mut r, 9.0);
    assert_eq!(r.fields.len(), fields_before + 2);
}

/// `c` pushed along the surface with `force` N in direction `direction_deg` (sensor frame),
/// using `friction_used` of the friction.
fn pushed(mut c: Contact, force: f64, direction_deg: f64, friction_used: f64) -> Contact {
    c.shear = Some(Shear {
        force: fringe_rig::Newtons(force),
        direction_deg,
        friction_used,
        sliding: false,
    });
    c
}

/// Sum of the fringe order over the pixels whose sensor-frame point lies ahead of (`ahead`) or
/// behind the point (x, y) along the unit direction (dx, dy).
fn order_beside(r: &Renderer, map: &[f32], (x, y): (f64, f64), (dx, dy): (f64, f64)) -> [f64; 2] {
    let g = r.geometry();
    let w = r.width() as usize;
    let mut sums = [0.0; 2];
    for (i, j) in disc_pixels(r, 0.9) {
        let [sx, sy] = g.to_sensor(i as f64 + 0.5, j as f64 + 0.5);
        let along = (sx - x) * dx + (sy - y) * dy;
        sums[usize::from(along < 0.0)] += f64::from(map[j * w + i]);
    }
    sums
}

#[test]
fn a_push_along_the_surface_makes_the_fringes_lopsided_towards_it() {
    for variant in [SensorConfig::layered(), SensorConfig::integrated()] {
        let mut c = quiet(variant);
        c.optics.blur_px = 0.0;
        let mut r = Renderer::new(c).expect("renderer");
        let press = contact(r.config().pentagon(), 5.0, 3.0, -2.0, 25.0);
        // No push, or a push of 0 N, is the press alone, bit for bit.
        let alone = r.fringe_order_map(&press);
        assert!(alone == r.fringe_order_map(&pushed(press, 0.0, 40.0, 0.3)));
        let [ahead0, behind0] = order_beside(&r, &alone, (3.0, -2.0), (1.0, 0.0));
        for (direction, (dx, dy)) in [(0.0, (1.0, 0.0)), (180.0, (-1.0, 0.0)), (90.0, (0.0, 1.0))] {
            let map = r.fringe_order_map(&pushed(press, 2.0, direction, 0.4));
            let [ahead, behind] = order_beside(&r, &map, (3.0, -2.0), (dx, dy));
            let [a0, b0] = if direction == 90.0 {
                order_beside(&r, &alone, (3.0, -2.0), (dx, dy))
            } else if direction == 0.0 {
                [ahead0, behind0]
            } else {
                [behind0, ahead0]
            };
            let lopsided = (ahead - behind) / (ahead + behind);
            let before = (a0 - b0) / (a0 + b0);
            eprintln!(
                "{}: push towards {direction} deg: (ahead - behind) / sum {lopsided:+.3}, press alone {before:+.3}",
                r.config().id
            );
            assert!(
                (lopsided - before).abs() > 0.03,
                "{}: a 2 N push towards {direction} deg left the fringes as they were ({lopsided} vs {before})",
                r.config().id
            );
        }
        // Pushing the other way tips the balance the other way.
        let east = r.fringe_order_map(&pushed(press, 2.0, 0.0, 0.4));
        let west = r.fringe_order_map(&pushed(press, 2.0, 180.0, 0.4));
        let [e_ahead, e_behind] = order_beside(&r, &east, (3.0, -2.0), (1.0, 0.0));
        let [w_ahead, w_behind] = order_beside(&r, &west, (3.0, -2.0), (1.0, 0.0));
        assert!(
            (e_ahead - e_behind - (ahead0 - behind0)) * (w_ahead - w_behind - (ahead0 - behind0))
                < 0.0,
            "pushes east and west moved the balance the same way"
        );
    }
}

#[test]
fn a_pushed_contact_turned_with_its_push_turns_the_image() {
    let mut c = quiet(SensorConfig::layered());
    c.leds.count = 0;
    c.optics.residual_birefringence = 0.0;
    c.optics.blur_px = 0.0;
    let mut r = Renderer::new(c).expect("renderer");
    let g = r.geometry();
    let shape = r.config().rectangle();
    let theta = 35.0f64;
    let (s, co) = theta.to_radians().sin_cos();
    let a = r.fringe_order_map(&pushed(contact(shape, 5.0, 0.0, 0.0, 10.0), 2.0, 20.0, 0.5));
    let b = r.fringe_order_map(&pushed(
        contact(shape, 5.0, 0.0, 0.0, 10.0 + theta),
        2.0,
        20.0 + theta,
        0.5,
    ));
    let w = r.width() as usize;
    let (mut diff, mut base, mut count) = (0.0, 0.0, 0.0);
    for (i, j) in disc_pixels(&r, 0.5) {
        let [sx, sy] = g.to_sensor(i as f64 + 0.5, j as f64 + 0.5);
        let [u, v] = g.to_pixel(co * sx + s * sy, -s * sx + co * sy);
        let (iu, jv) = (u as usize, v as usize);
        diff += f64::from((b[j * w + i] - a[jv * w + iu]).abs());
        base += f64::from((b[j * w + i] - a[j * w + i]).abs());
        count += 1.0;
    }
    let (diff, base) = (diff / count, base / count);
    eprintln!("turned push vs image turned {diff} orders, unturned {base}");
    assert!(diff < 0.2 * base, "{diff} vs {base}");
}

#[test]
fn a_held_push_draws_what_a_fresh_renderer_draws_bit_for_bit() {
    let mut r = Renderer::new(small(SensorConfig::layered())).expect("renderer");
    let press = contact(r.config().pentagon(), 5.0, 3.0, -2.0, 25.0);
    let held = pushed(press, 1.5, 40.0, 0.3);
    // Pushes that differ from `held` in one thing each: the field must not be taken for its.
    let others = [
        pushed(press, 1.5, 41.0, 0.3),
        pushed(press, 1.6, 40.0, 0.3),
        pushed(press, 1.5, 40.0, 0.31),
        pushed(
            contact(r.config().pentagon(), 5.1, 3.0, -2.0, 25.0),
            1.5,
            40.0,
            0.3,
        ),
        pushed(
            contact(r.config().pentagon(), 5.0, 3.0, -2.0, 26.0),
            1.5,
            40.0,
            0.3,
        ),
        pushed(
            contact(r.config().rectangle(), 5.0, 3.0, -2.0, 25.0),
            1.5,
            40.0,
            0.3,
        ),
    ];
    let fresh = |c: Contact| {
        let mut f = Renderer::new(small(SensorConfig::layered())).expect("renderer");
        render(&mut f, Some(c), 9)
    };
    let first = render(&mut r, Some(held), 9);
    assert!(
        first == fresh(held),
        "a pushed frame differs from a fresh renderer's"
    );
    // Held: the same field, not rebuilt, and the same frame.
    let (a, _) = r.contact_field(&held);
    let (b, _) = r.contact_field(&held);
    assert!(Arc::ptr_eq(&a, &b), "a held push rebuilt its field");
    drop((a, b));
    assert!(render(&mut r, Some(held), 9) == first);
    for other in others {
        let frame = render(&mut r, Some(other), 9);
        assert!(frame != first, "{other:?} drew the held push");
        assert!(
            frame == fresh(other),
            "{other:?} differs from a fresh renderer's"
        );
        // Back to the held push: rebuilt (in the last field's buffers), bit for bit.
        assert!(render(&mut r, Some(held), 9) == first);
    }
}

#[test]
fn the_pushed_field_is_the_fringe_field_of_the_summed_stresses() {
    use crate::optics::push_stress::{Grid, PushStress};
    let config = small(SensorConfig::integrated());
    let mut r = Renderer::new(config.clone()).expect("renderer");
    let shape = r.config().rectangle();
    let c = pushed(contact(shape, 4.0, 0.0, 0.0, 30.0), 2.0, 75.0, 0.55);
    let (field, factor) = r.contact_field(&c);
    assert_eq!(factor, 1.0);
    // The double-precision sum of FringeField::from_stress and PackedField::new.
    let (n, cell) = (config.field.cells, config.field.cell_mm);
    let mut store = PushStress::new(
        Grid {
            cells: n,
            cell_mm: cell,
            layer: config.layer(),
        },
        false,
    );
    let (key, quantised) = field_key(&shape);
    let outline = store.outline(key, &quantised);
    // 0.55 of the friction: 0.4 of the way from level 4 to level 5; the push 45 degrees off
    // the indenter's x axis.
    let (w, q) = (0.55f64 * 8.0 - 4.0, std::f64::consts::FRAC_1_SQRT_2 * 2.0);
    let (normal, low, high) = (outline.press(), outline.level(4), outline.level(5));
    let stress = (0..n * n).map(|i| {
        let t = |f: &[Complex<f32>; 2]| {
            let (x, y) = (f[0], f[1]);
            Complex::new(f64::from(x.re + y.re) * q, f64::from(x.im + y.im) * q)
        };
        let d_n = Complex::new(f64::from(normal[i].re), f64::from(normal[i].im));
        d_n * 4.0 + t(&low[i]) * (1.0 - w) + t(&high[i]) * w
    });
    let expected = PackedField::new(
        &FringeField::from_stress(n, cell, stress, r.f_sigma_n_per_m()),
        1.0,
    );
    let peak = expected
        .data
        .iter()
        .fold([0.0f32; 2], |m, v| [m[0].max(v[0]), m[1].max(v[1])]);
    assert!(peak[0] > 1.0 && peak[1] > 1.0, "{peak:?}");
    let mut worst = [0.0f32; 2];
    for (got, want) in field.data.iter().zip(&expected.data) {
        for k in 0..2 {
            worst[k] = worst[k].max((got[k] - want[k]).abs() / peak[k]);
        }
    }
    assert!(worst[0] < 1e-5 && worst[1] < 1e-4, "{worst:?} of {peak:?}");
    assert_eq!(field.beyond.len(), expected.beyond.len());
    let reach = |f: &PackedField| f.reach_mm(1.0, 0.05, 0.01);
    assert!(
        (reach(&field) - reach(&expected)).abs() <= expected.cell_mm,
        "reach"
    );
}
