//! NFF entities: the view, background and resolution, lights, fills and materials, spheres,
//! cylinders and cones, comments and line endings, patches and their normals.

use std::f64::consts::PI;

use cuberay::scene::{FovSpan, LightSource, Material, Primitive, Projection};
use glam::DVec3;

use super::{nff_error, parse_ok, triangles, VIEW};

#[test]
fn view_background_and_resolution() {
    let loaded = parse_ok(
        "b 0.1 0.2 0.3\nv\nfrom 1 2 3\nat 1 2 -7\nup 0 1 0\nangle 60\nhither 0.5\nresolution 320 200\ns 0 0 0 1\n",
    );
    let scene = &loaded.scene;
    assert_eq!(scene.background, DVec3::new(0.1, 0.2, 0.3));
    assert_eq!(scene.camera.eye, DVec3::new(1.0, 2.0, 3.0));
    assert!((scene.camera.forward - DVec3::NEG_Z).length() < 1e-15);
    assert!((scene.camera.up - DVec3::Y).length() < 1e-15);
    assert_eq!(
        scene.camera.projection,
        Projection::Perspective { fov_y: PI / 3.0, span: FovSpan::EdgePixelCenters }
    );
    assert_eq!(scene.camera.near, 0.5);
    assert_eq!(scene.resolution, Some((320, 200)));
}

#[test]
fn view_without_hither_or_resolution() {
    let loaded = parse_ok(&format!("{VIEW}s 0 0 0 1"));
    assert_eq!(loaded.scene.camera.near, 0.0);
    assert_eq!(loaded.scene.resolution, None);
    assert_eq!(loaded.scene.background, DVec3::ZERO, "no 'b' means black");
}

#[test]
fn lights_share_the_spd_intensity_and_ambient() {
    let loaded = parse_ok(&format!("{VIEW}l 1 2 3\nl 4 5 6 0.5 0.25 1\nl 7 8 9\nl 0 0 1\ns 0 0 0 1"));
    let scene = &loaded.scene;
    assert_eq!(scene.lights.len(), 4);
    let expected = 4f64.sqrt() / (2.0 * 4.0);
    for l in &scene.lights {
        assert_eq!(l.source, LightSource::File);
        assert!(!l.inverse_square);
        assert!((l.intensity - expected).abs() < 1e-15);
    }
    assert_eq!(scene.lights[0].position, DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(scene.lights[0].color, DVec3::ONE);
    assert_eq!(scene.lights[1].position, DVec3::new(4.0, 5.0, 6.0));
    assert_eq!(scene.lights[1].color, DVec3::new(0.5, 0.25, 1.0));
    assert_eq!(scene.lights[2].position, DVec3::new(7.0, 8.0, 9.0));
    assert!((scene.ambient - DVec3::splat(expected)).length() < 1e-15);
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
}

#[test]
fn no_light_gets_the_default_with_a_warning() {
    let loaded = parse_ok(&format!("{VIEW}s 0 0 0 1"));
    assert_eq!(loaded.scene.lights.len(), 1);
    assert_eq!(loaded.scene.lights[0].source, LightSource::Default);
    assert_eq!(loaded.scene.file_lights().count(), 0);
    assert_eq!(loaded.scene.ambient, DVec3::splat(0.5), "the ambient of a single light");
    assert!(loaded.warnings.iter().any(|w| w.contains("no light")), "{:?}", loaded.warnings);
}

#[test]
fn fill_maps_onto_the_whitted_material() {
    let loaded = parse_ok(&format!(
        "{VIEW}f 1 0.5 0.25 0.7 0.3 20 0.6 1.5\ns 0 0 0 1\nf 0.2 0.2 0.2 1 0 100000 0 0\ns 3 0 0 1"
    ));
    let m = &loaded.scene.materials;
    assert_eq!(m.len(), 2, "one material per 'f', no default when unused");
    assert_eq!(m[0].color, DVec3::new(1.0, 0.5, 0.25));
    assert_eq!((m[0].kd, m[0].ks, m[0].shine, m[0].transmittance, m[0].ior), (0.7, 0.3, 20.0, 0.6, 1.5));
    assert_eq!(m[0].mirror, DVec3::splat(0.3));
    assert_eq!(m[0].emission, DVec3::ZERO);
    assert_eq!(m[1].ior, 1.0, "opaque 'f' with ior 0 (as SPD writes) stores 1");
    assert_eq!(m[1].mirror, DVec3::ZERO);
    assert_eq!(loaded.scene.primitives[0].material(), 0);
    assert_eq!(loaded.scene.primitives[1].material(), 1);
}

#[test]
fn default_material_only_before_the_first_fill() {
    let loaded = parse_ok(&format!(
        "{VIEW}s 0 0 0 1\nf 1 0 0 1 0 1 0 1\ns 3 0 0 1\nf 0 1 0 1 0 1 0 1\nf 0 0 1 1 0 1 0 1\n"
    ));
    let scene = &loaded.scene;
    assert_eq!(scene.materials.len(), 4);
    assert_eq!(scene.materials[0], Material::default());
    assert_eq!(scene.primitives[0].material(), 0);
    assert_eq!(scene.primitives[1].material(), 1);
    assert_eq!(scene.materials[1].color, DVec3::X);
}

#[test]
fn spheres_and_negative_radius() {
    let loaded = parse_ok(&format!("{VIEW}s 1 2 3 0.5\ns 0 0 0 -2"));
    let Primitive::Sphere(a) = &loaded.scene.primitives[0] else { panic!() };
    let Primitive::Sphere(b) = &loaded.scene.primitives[1] else { panic!() };
    assert_eq!((a.center, a.radius, a.inside_only), (DVec3::new(1.0, 2.0, 3.0), 0.5, false));
    assert_eq!((b.radius, b.inside_only), (2.0, true));
}

#[test]
fn cylinders_cones_and_their_layouts() {
    // The spec's three-line layout and the generators' one-line layout read the same.
    let three = parse_ok(&format!("{VIEW}c\n0 0 0 1\n0 0 2 0.5\n"));
    let one = parse_ok(&format!("{VIEW}c 0 0 0 1 0 0 2 0.5\n"));
    assert_eq!(three.scene.primitives, one.scene.primitives);
    let Primitive::Cylinder(c) = &one.scene.primitives[0] else { panic!() };
    assert_eq!(
        (c.base, c.base_radius, c.apex, c.apex_radius),
        (DVec3::ZERO, 1.0, DVec3::new(0.0, 0.0, 2.0), 0.5)
    );
    assert!(!c.inside_only);

    let loaded = parse_ok(&format!("{VIEW}c 0 0 0 -1 0 0 2 -1\nc 0 0 0 1 0 0 1 0\nc 0 0 0 -1 0 0 1 0"));
    let cyl: Vec<_> = loaded
        .scene
        .primitives
        .iter()
        .map(|p| if let Primitive::Cylinder(c) = p { c.clone() } else { panic!() })
        .collect();
    assert!(cyl[0].inside_only && cyl[0].base_radius == 1.0 && cyl[0].apex_radius == 1.0);
    assert!(!cyl[1].inside_only && cyl[1].apex_radius == 0.0, "a cone may end in a point");
    assert!(cyl[2].inside_only);
}

#[test]
fn comments_and_line_endings() {
    let text = format!(
        "# a scene\r\n{}s 0 0 0 1 # trailing comment\r\ns 2 0 0 1#glued\r\n# s 9 9 9 9\r\n",
        VIEW.replace('\n', "\r\n")
    );
    let loaded = parse_ok(&text);
    assert_eq!(loaded.scene.counts().spheres, 2);
    // Line numbers still count from 1 with comments and CRLF.
    nff_error(&format!("{text}s 0 0 0 zero\r\n"), 8, &["sphere radius"]);
}

#[test]
fn patches_keep_their_normals() {
    let n0 = DVec3::new(0.0, 0.0, 2.0);
    let n1 = DVec3::new(0.6, 0.0, 0.8);
    let n2 = DVec3::new(0.0, -3.0, 4.0);
    let loaded = parse_ok(&format!(
        "{VIEW}pp 3\n0 0 0 {} {} {}\n1 0 0 {} {} {}\n0 1 0 {} {} {}\n",
        n0.x, n0.y, n0.z, n1.x, n1.y, n1.z, n2.x, n2.y, n2.z
    ));
    let t = triangles(&loaded)[0];
    let n = t.n.expect("pp keeps its normals");
    for (got, want) in n.iter().zip([n0, n1, n2]) {
        assert!((*got - want.normalize()).length() < 1e-15, "{got} != {want} normalised");
    }
    assert!(loaded.warnings.iter().all(|w| !w.contains("normal")));
    // A plain polygon has no shading normals.
    assert!(triangles(&parse_ok(&format!("{VIEW}p 3 0 0 0 1 0 0 0 1 0")))[0].n.is_none());
}

#[test]
fn patch_normals_follow_the_polygon_through_triangulation() {
    // A concave patch (an L) whose normals encode the vertex index: each triangle corner
    // must carry the normal given with its position.
    let outline = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)];
    let normal_of = |x: f64, y: f64| DVec3::new(x - 1.0, y - 1.0, 3.0).normalize();
    let mut text = format!("{VIEW}pp {}\n", outline.len());
    for (x, y) in outline {
        let n = normal_of(x, y);
        text += &format!("{x} {y} 0 {} {} {}\n", n.x, n.y, n.z);
    }
    let loaded = parse_ok(&text);
    let tris = triangles(&loaded);
    assert_eq!(tris.len(), 4);
    for t in tris {
        for (p, n) in t.p.iter().zip(t.n.unwrap()) {
            assert!((n - normal_of(p.x, p.y)).length() < 1e-12);
        }
    }
}

#[test]
fn zero_patch_normal_becomes_the_geometric_normal() {
    let loaded = parse_ok(&format!("{VIEW}pp 3\n0 0 0 0 0 0\n1 0 0 0 0 1\n0 1 0 0 0 1\n"));
    let n = triangles(&loaded)[0].n.unwrap();
    assert_eq!(n[0], DVec3::Z);
    assert!(
        loaded.warnings.iter().any(|w| w.contains("normal") && w.contains("line 4")),
        "{:?}",
        loaded.warnings
    );
}
