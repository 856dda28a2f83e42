//! Property tests of the tables against brute force: random scenes of spheres, triangles and
//! cylinders, eye rays anywhere in the image, and shadow and nearest-hit rays from the
//! lights.

use glam::DVec3;
use proptest::prelude::*;

use cuberay::coherence::OriginKey;
use cuberay::scene::{Primitive, Scene};

use super::{cyl, scene, small_params, sphere, tri, World};

fn arb_vec(r: f64) -> impl Strategy<Value = DVec3> {
    (-r..r, -r..r, -r..r).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn arb_prim() -> impl Strategy<Value = Primitive> {
    let m = 0u32..3;
    prop_oneof![
        (arb_vec(4.0), 0.05f64..1.5, m.clone()).prop_map(|(c, r, m)| sphere(c, r, m)),
        (arb_vec(4.0), arb_vec(1.5), arb_vec(1.5), m.clone()).prop_filter_map(
            "degenerate",
            |(c, a, b, m)| {
                let t = tri(c, c + a, c + b, m);
                match &t {
                    Primitive::Triangle(x) if !x.is_degenerate() && x.cross().length() > 1e-3 => Some(t),
                    _ => None,
                }
            }
        ),
        (arb_vec(4.0), arb_vec(1.5), 0.05f64..0.6, 0.0f64..0.6, m)
            .prop_filter_map("short", |(a, v, ra, rb, m)| {
                (v.length() > 0.05).then(|| cyl(a, ra, a + v, rb.max(0.01), m))
            }),
    ]
}

fn arb_scene() -> impl Strategy<Value = Scene> {
    (
        proptest::collection::vec(arb_prim(), 1..10),
        arb_vec(7.0),
        arb_vec(2.0),
        proptest::collection::vec(arb_vec(7.0), 1..3),
    )
        .prop_filter_map("camera", |(prims, eye, at, lights)| {
            ((at - eye).length() > 0.1).then(|| scene(eye, at, &lights, prims))
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]

    /// Eye rays anywhere in the image: the walker's nearest hit is brute force's.
    #[test]
    fn eye_rays_match_brute_force(s in arb_scene(), pts in proptest::collection::vec((0.0f64..64.0, 0.0f64..64.0), 40)) {
        let w = World::new(&s, &small_params());
        for (x, y) in pts {
            let (o, d) = s.camera.ray(x, y, 64, 64);
            w.check_nearest(OriginKey::Eye, w.p(o), d.as_vec3().normalize()).map_err(TestCaseError::fail)?;
        }
    }

    /// Shadow rays from each light toward random points (any-hit with a distance limit) and
    /// nearest hits from the light in any direction.
    #[test]
    fn light_rays_match_brute_force(s in arb_scene(), pts in proptest::collection::vec(arb_vec(6.0), 30), frac in 0.05f32..1.0) {
        let w = World::new(&s, &small_params());
        for (li, l) in s.lights.iter().enumerate() {
            let lp = w.p(l.position);
            for q in &pts {
                let v = w.p(*q) - lp;
                if v.length() < 1e-3 { continue; }
                let d = v.normalize();
                w.check_any(OriginKey::Light(li), lp, d, v.length() * frac).map_err(TestCaseError::fail)?;
                w.check_nearest(OriginKey::Light(li), lp, d).map_err(TestCaseError::fail)?;
            }
        }
    }
}
