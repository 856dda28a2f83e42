//! Every binding the WGSL declares is the one `gpu::bindings` declares for its family: the
//! same number, variable name and access, in group 0; and every binding a family declares
//! is used by some kernel of it. The composed kernels are read through naga; no GPU is
//! needed.

use std::collections::BTreeMap;

use cuberay::gpu::bindings::{Access, Binding, SceneBinding, ACCUMULATE, DISPLAY};
use cuberay::gpu::shaders::{compose, Accel, Kernel, Variant};

/// The bindings a kernel of `variant` declares: number → (name, access).
fn declared(kernel: Kernel, variant: Variant) -> BTreeMap<u32, (String, Access)> {
    let src = compose(kernel, variant).unwrap();
    let module = naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{}: {e}", kernel.name()));
    let mut out = BTreeMap::new();
    for (_, var) in module.global_variables.iter() {
        let Some(rb) = &var.binding else { continue };
        assert_eq!(rb.group, 0, "{}: {:?} is not in group 0", kernel.name(), var.name);
        let access = match (var.space, &module.types[var.ty].inner) {
            (_, naga::TypeInner::AccelerationStructure { .. }) => Access::AccelerationStructure,
            (naga::AddressSpace::Storage { access }, _) if access.contains(naga::StorageAccess::STORE) => {
                Access::ReadWrite
            }
            (naga::AddressSpace::Storage { .. }, _) => Access::Read,
            (space, ty) => panic!("{}: {:?} is a {space:?} {ty:?}", kernel.name(), var.name),
        };
        out.insert(rb.binding, (var.name.clone().unwrap_or_default(), access));
    }
    out
}

/// Checks the bindings `kernel` of `variant` declares against `family`, and records which
/// numbers it used.
fn check(kernel: Kernel, variant: Variant, family: &[Binding], used: &mut Vec<u32>) {
    for (number, (name, access)) in declared(kernel, variant) {
        let want = family
            .iter()
            .find(|b| b.number == number)
            .unwrap_or_else(|| panic!("{}: binding {number} ({name}) is not in its family", kernel.name()));
        assert_eq!((name.as_str(), access), (want.name, want.access), "{}: binding {number}", kernel.name());
        used.push(number);
    }
}

/// Every family member is used by some kernel.
fn all_used(family: &[Binding], used: &[u32], what: &str) {
    for b in family {
        assert!(used.contains(&b.number), "{what}: no kernel declares {} ({})", b.number, b.name);
    }
}

#[test]
fn the_tracing_kernels_bind_the_scene_family() {
    let family: Vec<Binding> = SceneBinding::ALL.iter().map(|b| b.binding()).collect();
    let mut used = Vec::new();
    let tracing =
        [Kernel::Nearest, Kernel::Shade, Kernel::Shadow, Kernel::Resolve, Kernel::Aov, Kernel::Tree];
    for f64 in [false, true] {
        let variants = Accel::GPU.map(|a| Variant { f64, ..Variant::full(a) }).into_iter().chain([
            Variant { f64, ..Variant::full(Accel::Cube) }.with_surface_rq(true),
            Variant { f64, split_prims: true, ..Variant::full(Accel::Bvh) },
        ]);
        for v in variants {
            for k in tracing {
                check(k, v, &family, &mut used);
            }
        }
    }
    all_used(&family, &used, "the scene family");
}

#[test]
fn the_preview_passes_bind_their_families() {
    let mut used = Vec::new();
    check(Kernel::Accumulate, Variant::default(), &ACCUMULATE, &mut used);
    all_used(&ACCUMULATE, &used, "accumulate");
    let mut used = Vec::new();
    check(Kernel::Display, Variant::default(), &DISPLAY, &mut used);
    all_used(&DISPLAY, &used, "display");
}

#[test]
fn numbers_and_names_are_unique_in_each_family() {
    let scene: Vec<Binding> = SceneBinding::ALL.iter().map(|b| b.binding()).collect();
    for family in [&scene[..], &ACCUMULATE[..], &DISPLAY[..]] {
        for (i, a) in family.iter().enumerate() {
            for b in &family[i + 1..] {
                assert!(a.number != b.number && a.name != b.name, "{a:?} and {b:?}");
            }
        }
    }
}
