//! The maps' own scenes (`scenes/*.gltf`, from `scenes/make_maps.py`) on both backends
//! against closed forms, pixel by pixel: vertex colours, an alpha-masked and a blended
//! checker over a lit wall, a half-metal texture, a tilted normal map.

use cuberay::job::{RenderOptions, Rendered};
use cuberay::load;
use cuberay::scene::Scene;
use glam::DVec3;

use super::agree;

/// Vertex colours (glTF COLOR_0 as normalised bytes, `scenes/vertex_colors.gltf`) tint as
/// given: under a light that reaches every point of the quad alike, each pixel is the
/// colour interpolated from its triangle's vertices times one number, on the GPU and the
/// CPU (which agree, FLIP ≤ 0.01).
#[test]
fn vertex_colors_tint_as_given() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/vertex_colors.gltf");
    let scene = load::load(&path, &Default::default()).unwrap_or_else(|e| panic!("{e}")).scene;
    assert!(scene.effects().vertex_colors);
    let opts = RenderOptions::new(48, 48);
    let (g, c) = agree("vertex_colors", &scene, &opts, 0.01);
    assert!(g.stats.effects.contains(&"vertex_colors"), "{:?}", g.stats.effects);
    // Corners red (-1, -1), green (1, -1), blue (1, 1), white (-1, 1); triangles (0, 1, 2)
    // below the diagonal y = x and (0, 2, 3) above it.
    let v = [
        DVec3::new(-1.0, -1.0, 0.0),
        DVec3::new(1.0, -1.0, 0.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(-1.0, 1.0, 0.0),
    ];
    let col = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
    let (mut checked, mut worst) = (0, 0.0f64);
    for y in 0..opts.height {
        for x in 0..opts.width {
            let (o, d) = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, opts.width, opts.height);
            let p = o + d * (-o.z / d.z);
            if p.x.abs() > 0.95 || p.y.abs() > 0.95 || (p.x - p.y).abs() < 0.05 {
                continue;
            }
            let [a, b, e] = if p.y < p.x { [0, 1, 2] } else { [0, 2, 3] };
            // Barycentrics in the plane z = 0.
            let area = |p: DVec3, q: DVec3, r: DVec3| (q - p).truncate().perp_dot((r - p).truncate());
            let whole = area(v[a], v[b], v[e]);
            let (wa, wb) = (area(p, v[b], v[e]) / whole, area(v[a], p, v[e]) / whole);
            let want = col[a] * wa + col[b] * wb + col[e] * (1.0 - wa - wb);
            for (backend, img) in [("GPU", &g.image), ("CPU", &c.image)] {
                let px = img.get(x, y);
                let got = DVec3::new(px[0] as f64, px[1] as f64, px[2] as f64);
                // The one number: the least-squares scale of `want` onto `got`.
                let k = got.dot(want) / want.dot(want);
                let off = (got - want * k).abs().max_element() / got.max_element();
                assert!(
                    k > 0.05 && off < 0.01,
                    "{backend} ({x}, {y}) at {p}: {got} is not a multiple of {want}"
                );
                worst = worst.max(off);
            }
            checked += 1;
        }
    }
    assert!(checked > 1000, "{checked} pixels checked");
    eprintln!(
        "vertex_colors: {checked} pixels, each within {worst:.1e} of its vertex colour times one number"
    );
}

/// A scene of the project's own `scenes/`.
fn own_scene(file: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(file);
    load::load(&path, &Default::default()).unwrap_or_else(|e| panic!("{file}: {e}")).scene
}

/// The linear RGB of pixel (`x`, `y`).
fn rgb(img: &cuberay::output::Image, x: u32, y: u32) -> DVec3 {
    let px = img.get(x, y);
    DVec3::new(px[0] as f64, px[1] as f64, px[2] as f64)
}

/// An alpha-masked checker (`scenes/alpha_mask.gltf`, from `scenes/make_maps.py`: 4×4
/// texels, nearest, cutoff 0.5) in front of a lit wall, seen straight on: its opaque texels
/// glow red, its clear ones show the wall, whose points are in the checker's shadow exactly
/// where the ray towards the tilted sun meets an opaque texel. On both backends, pixel by
/// pixel, and they agree (FLIP ≤ 0.01).
#[test]
fn alpha_mask_shows_the_wall_through_exactly_the_clear_texels() {
    let scene = own_scene("alpha_mask.gltf");
    assert!(scene.effects().alpha && !scene.effects().blend, "{:?}", scene.effects());
    checker_over_wall("alpha_mask", &scene, 1.0);
}

/// The same checker blended (glTF BLEND) with its opaque texels at alpha 0.6: each of their
/// pixels is 0.6 of the red glow and 0.4 of the wall behind (a pass-through ray), its clear
/// texels show the wall, and shadow rays take it as masked at 0.5, so its shadow is the
/// masked checker's.
#[test]
fn alpha_blend_lets_one_minus_alpha_through() {
    let mut scene = own_scene("alpha_mask.gltf");
    scene.materials[0].alpha = cuberay::scene::Alpha::Blend;
    scene.materials[0].opacity = 0.6;
    assert!(scene.effects().blend && !scene.effects().alpha, "{:?}", scene.effects());
    let (g, _) = checker_over_wall("alpha_blend", &scene, 0.6);
    assert!(g.stats.rays.refract > 0, "pass-through rays are counted as refraction rays");
}

/// Renders the checker over the wall on both backends and checks every pixel against the
/// closed form for opaque texels of alpha `a` (1: masked).
fn checker_over_wall(name: &str, scene: &Scene, a: f64) -> (Rendered, Rendered) {
    let opts = RenderOptions::new(64, 64);
    let (g, c) = agree(name, scene, &opts, 0.01);
    // Texel (i, j) of the quad [-1, 1]² (v downwards) at a point of the plane; opaque where
    // i + j is even.
    let opaque = |x: f64, y: f64| {
        let (i, j) = (((x + 1.0) * 2.0).floor(), ((1.0 - y) * 2.0).floor());
        (0.0..4.0).contains(&i) && (0.0..4.0).contains(&j) && (i + j) as i64 % 2 == 0
    };
    let to_sun = -scene.lights[0].direction;
    let (mut holes, mut shadowed) = (0, 0);
    for y in 0..opts.height {
        for x in 0..opts.width {
            let (o, d) = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, opts.width, opts.height);
            let p = o + d * (-o.z / d.z);
            // The wall point behind, lit unless its ray to the sun crosses z = 0 in an
            // opaque texel: its blue glow plus the lit grey.
            let w = o + d * ((-1.0 - o.z) / d.z);
            let q = w + to_sun * (1.0 / to_sun.z);
            let lit = if opaque(q.x, q.y) { 0.0 } else { 0.5 * to_sun.z };
            let wall = DVec3::new(lit, lit, lit + 0.5);
            let want = if opaque(p.x, p.y) {
                DVec3::X * a + wall * (1.0 - a)
            } else {
                holes += 1;
                shadowed += (lit == 0.0) as u32;
                wall
            };
            for (backend, img) in [("GPU", &g.image), ("CPU", &c.image)] {
                let got = rgb(img, x, y);
                assert!(
                    (got - want).abs().max_element() < 1e-4,
                    "{name}: {backend} ({x}, {y}) at {p}: {got}, not {want}"
                );
            }
        }
    }
    assert!(
        holes == 64 * 32 && shadowed > 200 && shadowed < holes,
        "{holes} hole pixels, {shadowed} in shadow"
    );
    assert!(g.stats.effects.contains(&if a < 1.0 { "blend" } else { "alpha" }), "{:?}", g.stats.effects);
    (g, c)
}

/// A floor whose metallic-roughness texture is smooth metal on its left half and rough
/// dielectric on its right (`scenes/metal_half.gltf`) mirrors the green card only on the
/// metal half; the rough half is plain grey. Both backends, which agree (FLIP ≤ 0.01).
#[test]
fn half_metal_texture_reflects_only_on_the_metal_half() {
    let scene = own_scene("metal_half.gltf");
    let e = scene.effects();
    assert!(e.maps && e.reflection && !e.refraction, "{e:?}");
    let opts = RenderOptions::new(64, 64);
    let (g, c) = agree("metal_half", &scene, &opts, 0.01);
    for (backend, img) in [("GPU", &g.image), ("CPU", &c.image)] {
        let (mut green_left, mut grey_right) = (0, 0);
        for y in 0..opts.height {
            for x in 0..opts.width {
                let (o, d) = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, opts.width, opts.height);
                let p = o + d * (-o.y / d.y);
                if d.y >= 0.0 || p.x.abs() > 1.9 || p.x.abs() < 0.1 || p.z.abs() > 1.9 {
                    continue;
                }
                let px = rgb(img, x, y);
                if p.x < 0.0 {
                    green_left += (px.y > 0.5 && px.x < 0.05 && px.z < 0.05) as u32;
                } else {
                    // Rough, non-metallic: kd·base under the overhead sun, and no mirror.
                    assert!(
                        (px - DVec3::splat(0.8)).abs().max_element() < 1e-3,
                        "{backend} ({x}, {y}): {px}"
                    );
                    grey_right += 1;
                }
            }
        }
        assert!(green_left > 100 && grey_right > 300, "{backend}: {green_left} green, {grey_right} grey");
    }
    assert!(g.stats.rays.reflect > 0);
}

/// A one-texel normal map tilts every normal of a quad towards +x and +y, near the half-way
/// vector of the light and the viewer (`scenes/normal_tilt.gltf`): each pixel is the closed
/// form's diffuse kd·C·(n'·L) plus Phong highlight ks·(R'·V)^shine for the tilted normal n'
/// (a flat normal's highlight is 0.577^76: none), on the half with a TANGENT attribute and on
/// the half whose tangents come from MikkTSpace alike (so both agree on glTF's +Y: up the
/// image, where v grows down), on both backends, which agree (FLIP ≤ 0.01).
#[test]
fn normal_map_tilts_shading_as_the_closed_form_says() {
    let scene = own_scene("normal_tilt.gltf");
    assert!(scene.effects().normal_maps, "{:?}", scene.effects());
    let opts = RenderOptions::new(48, 48);
    let (g, c) = agree("normal_tilt", &scene, &opts, 0.01);
    assert!(g.stats.effects.contains(&"normal_maps"), "{:?}", g.stats.effects);
    // Texel (169, 169, 241) in tangent space: T = +x (u grows right), B = +y (up the image),
    // N = +z.
    let t = |c: f64| 2.0 * c / 255.0 - 1.0;
    let m = &scene.materials[0];
    let l = -scene.lights[0].direction;
    let shade = |n: DVec3| {
        let r = n * (2.0 * n.dot(l)) - l;
        0.5 * m.kd * n.dot(l) + m.ks * r.dot(DVec3::Z).max(0.0).powf(m.shine)
    };
    let want = shade(DVec3::new(t(169.0), t(169.0), t(241.0)).normalize());
    let flat = shade(DVec3::Z);
    assert!(m.ks > 0.01 && (m.shine - 76.125).abs() < 1e-3, "{m:?}");
    for (backend, img) in [("GPU", &g.image), ("CPU", &c.image)] {
        for y in 0..opts.height {
            for x in 0..opts.width {
                let got = rgb(img, x, y);
                assert!(
                    (got - DVec3::splat(want)).abs().max_element() < 1e-4,
                    "{backend} ({x}, {y}): {got}, not {want}"
                );
            }
        }
    }
    eprintln!("normal_tilt: every pixel {want:.5} (an untilted normal gives {flat:.5})");
    assert!(want - flat > 0.1);
}
