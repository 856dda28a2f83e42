//! The kernels' bindings, declared once per kernel family: each binding's number, the name
//! of its WGSL variable, and what the kernels may do with it. The bind group layouts and the
//! bind groups are made from these tables, and `tests/it/bindings.rs` checks every binding
//! the WGSL declares against them through naga, as `tests/it/twins.rs` does for structs.
//!
//! - [`SceneBinding`]: the scene's buffers, which every tracing kernel (the wavefront's and
//!   `aov`) binds in group 0 (`shaders/shared/layout.wgsl`, `wavefront.wgsl`,
//!   `counters.wgsl`, `tables.wgsl`, `bvh.wgsl`, `rayquery.wgsl`); a kernel declares only
//!   the bindings of its own queries, and the layout holds them all;
//! - [`ACCUMULATE`]: the preview's accumulation pass (`shaders/accumulate.wgsl`);
//! - [`DISPLAY`]: the preview's display pass (`shaders/display.wgsl`).

/// What a kernel may do with a binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// A storage buffer the kernels read (`var<storage, read>`).
    Read,
    /// A storage buffer the kernels write (`var<storage, read_write>`).
    ReadWrite,
    /// The platform's ray-tracing structure (`acceleration_structure`).
    AccelerationStructure,
}

/// One binding of a family: its number in group 0, its WGSL variable, its access.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    pub number: u32,
    pub name: &'static str,
    pub access: Access,
}

const fn read(number: u32, name: &'static str) -> Binding {
    Binding { number, name, access: Access::Read }
}

const fn write(number: u32, name: &'static str) -> Binding {
    Binding { number, name, access: Access::ReadWrite }
}

/// The scene's buffers as the tracing kernels bind them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneBinding {
    /// The kernels' parameters: a read-only storage buffer, not a uniform, since lavapipe
    /// would compile a variant of the kernel for every tile's values.
    Params,
    Prims,
    Materials,
    Lights,
    TriAttrs,
    TextureInfos,
    Texels,
    /// Each tile point's colour (`resolve`) or AOV (`aov`).
    OutColor,
    Counters,
    Jobs,
    Queues,
    Origins,
    Faces,
    CellStart,
    Entries,
    LightOrigin,
    BvhNodes,
    BvhPrims,
    PassDesc,
    /// The tile's radiance sums in fixed point.
    Accum,
    BvhParents,
    /// The ray queries' top-level structure (only where the kernels use ray queries).
    RqScene,
    /// The primitives past what one binding holds (`SPLIT_PRIMS`; placeholders otherwise).
    Prims1,
    Prims2,
    Prims3,
}

impl SceneBinding {
    pub const ALL: [SceneBinding; 25] = [
        SceneBinding::Params,
        SceneBinding::Prims,
        SceneBinding::Materials,
        SceneBinding::Lights,
        SceneBinding::TriAttrs,
        SceneBinding::TextureInfos,
        SceneBinding::Texels,
        SceneBinding::OutColor,
        SceneBinding::Counters,
        SceneBinding::Jobs,
        SceneBinding::Queues,
        SceneBinding::Origins,
        SceneBinding::Faces,
        SceneBinding::CellStart,
        SceneBinding::Entries,
        SceneBinding::LightOrigin,
        SceneBinding::BvhNodes,
        SceneBinding::BvhPrims,
        SceneBinding::PassDesc,
        SceneBinding::Accum,
        SceneBinding::BvhParents,
        SceneBinding::RqScene,
        SceneBinding::Prims1,
        SceneBinding::Prims2,
        SceneBinding::Prims3,
    ];

    /// The bindings that hold buffers: all but the ray queries' structure.
    pub const BUFFERS: [SceneBinding; 24] = {
        let mut out = [SceneBinding::Params; 24];
        let (mut i, mut j) = (0, 0);
        while i < SceneBinding::ALL.len() {
            if !matches!(SceneBinding::ALL[i], SceneBinding::RqScene) {
                out[j] = SceneBinding::ALL[i];
                j += 1;
            }
            i += 1;
        }
        out
    };

    /// The bindings the primitives are split over, in order (`SPLIT_PRIMS`).
    pub const PRIMS: [SceneBinding; 4] =
        [SceneBinding::Prims, SceneBinding::Prims1, SceneBinding::Prims2, SceneBinding::Prims3];

    /// The binding's number, WGSL variable and access: the one place they are declared.
    pub const fn binding(self) -> Binding {
        match self {
            SceneBinding::Params => read(0, "params"),
            SceneBinding::Prims => read(1, "prims"),
            SceneBinding::Materials => read(2, "materials"),
            SceneBinding::Lights => read(3, "lights"),
            SceneBinding::TriAttrs => read(4, "tri_attrs"),
            SceneBinding::TextureInfos => read(5, "texture_infos"),
            SceneBinding::Texels => read(6, "texels"),
            SceneBinding::OutColor => write(7, "out_color"),
            SceneBinding::Counters => write(8, "counters"),
            SceneBinding::Jobs => write(9, "jobs"),
            SceneBinding::Queues => write(10, "queues"),
            SceneBinding::Origins => read(11, "origins"),
            SceneBinding::Faces => read(12, "faces"),
            SceneBinding::CellStart => read(13, "cell_start"),
            SceneBinding::Entries => read(14, "entries"),
            SceneBinding::LightOrigin => read(15, "light_origin"),
            SceneBinding::BvhNodes => read(20, "bvh_nodes"),
            SceneBinding::BvhPrims => read(21, "bvh_prims"),
            SceneBinding::PassDesc => read(22, "pass_desc"),
            SceneBinding::Accum => write(23, "accum"),
            SceneBinding::BvhParents => read(24, "bvh_parents"),
            SceneBinding::RqScene => {
                Binding { number: 25, name: "rq_scene", access: Access::AccelerationStructure }
            }
            SceneBinding::Prims1 => read(26, "prims_1"),
            SceneBinding::Prims2 => read(27, "prims_2"),
            SceneBinding::Prims3 => read(28, "prims_3"),
        }
    }

    /// The scene family's bindings: all of them with the ray queries' structure (`rq`), else
    /// all but it.
    pub fn family(rq: bool) -> impl Iterator<Item = SceneBinding> {
        SceneBinding::ALL.into_iter().filter(move |b| rq || *b != SceneBinding::RqScene)
    }
}

/// The accumulation pass's bindings: which points the finished tile holds, the tile's
/// colours, the accumulation.
pub const ACCUMULATE: [Binding; 3] = [read(0, "tile"), read(1, "tile_out"), write(2, "accum")];

/// The display pass's bindings: how to show the accumulation, and the accumulation.
pub const DISPLAY: [Binding; 2] = [read(0, "view"), read(1, "image")];

/// The layout entry of `b`, seen by the shader stages `visibility`.
pub fn layout_entry(b: Binding, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    let ty = match b.access {
        Access::Read | Access::ReadWrite => wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: b.access == Access::Read },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        Access::AccelerationStructure => wgpu::BindingType::AccelerationStructure { vertex_return: false },
    };
    wgpu::BindGroupLayoutEntry { binding: b.number, visibility, ty, count: None }
}

/// A bind group layout of `bindings`, seen by `visibility`.
pub fn layout(
    device: &wgpu::Device,
    label: &str,
    bindings: impl IntoIterator<Item = Binding>,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayout {
    let entries: Vec<wgpu::BindGroupLayoutEntry> =
        bindings.into_iter().map(|b| layout_entry(b, visibility)).collect();
    device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries: &entries })
}

/// A bind group of `buffers`, one for each binding of a family, in its order.
pub fn buffers_group<const N: usize>(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    family: &[Binding; N],
    buffers: [&wgpu::Buffer; N],
) -> wgpu::BindGroup {
    let entries = std::array::from_fn::<_, N, _>(|i| wgpu::BindGroupEntry {
        binding: family[i].number,
        resource: buffers[i].as_entire_binding(),
    });
    device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries: &entries })
}
