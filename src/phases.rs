//! Where a command's time goes, in the order a user waits for it ([`Phases`]): opening the
//! GPU, loading the scene, building what the rays walk, uploading it, making the kernels,
//! tracing, writing the image. `render --stats` reports them, and `cuberay bench` reports them
//! per accelerator as the time to an image.

use serde::{Deserialize, Serialize};

/// Seconds of wall clock by phase; a phase a command does not run stays 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Phases {
    /// Opening the GPU: the instance, the adapter and the device (0 on the CPU).
    pub startup_s: f64,
    /// Reading the scene file and setting the scene up (camera, environment).
    pub load_s: f64,
    /// Preparing the render: resolving the options, packing the scene, building the candidate
    /// tables (or reading stored ones) and the BVH.
    pub build_s: f64,
    /// Of `build_s`, the candidate tables.
    pub tables_s: f64,
    /// Of `build_s`, the BVH (the wide BVH's build and layout, or the ray queries' boxes).
    pub bvh_s: f64,
    /// Creating and filling the GPU's buffers, the driver's build of the ray queries'
    /// structure included.
    pub upload_s: f64,
    /// Making the kernels' pipelines and dispatching each once (lavapipe compiles a kernel at
    /// its first dispatch, or reads it from Mesa's cache).
    pub compile_s: f64,
    /// Running the kernels over the image, readbacks included (host clock).
    pub trace_s: f64,
    /// Encoding and writing the image.
    pub output_s: f64,
    /// The whole command, from its start to its end.
    pub total_s: f64,
}

impl std::ops::Add for Phases {
    type Output = Phases;

    /// The phases of two pieces of work done one after the other (the parts of a split render).
    fn add(self, o: Phases) -> Phases {
        Phases {
            startup_s: self.startup_s + o.startup_s,
            load_s: self.load_s + o.load_s,
            build_s: self.build_s + o.build_s,
            tables_s: self.tables_s + o.tables_s,
            bvh_s: self.bvh_s + o.bvh_s,
            upload_s: self.upload_s + o.upload_s,
            compile_s: self.compile_s + o.compile_s,
            trace_s: self.trace_s + o.trace_s,
            output_s: self.output_s + o.output_s,
            total_s: self.total_s + o.total_s,
        }
    }
}

impl Phases {
    /// The phases as one line of text: each that ran, and the whole.
    pub fn to_text(&self) -> String {
        let parts = [
            ("startup", self.startup_s),
            ("load", self.load_s),
            ("build", self.build_s),
            ("upload", self.upload_s),
            ("compile", self.compile_s),
            ("trace", self.trace_s),
            ("output", self.output_s),
        ];
        let mut s: Vec<String> =
            parts.iter().filter(|(_, t)| *t > 0.0).map(|(n, t)| format!("{n} {t:.3}")).collect();
        if self.tables_s > 0.0 || self.bvh_s > 0.0 {
            s.push(format!("(build: tables {:.3}, bvh {:.3})", self.tables_s, self.bvh_s));
        }
        format!("time to image {:.3} s: {}", self.total_s, s.join(", "))
    }

    /// The time to an image: every phase but the output, or the measured whole where there is one.
    pub fn whole(&self) -> f64 {
        if self.total_s > 0.0 {
            return self.total_s;
        }
        self.startup_s
            + self.load_s
            + self.build_s
            + self.upload_s
            + self.compile_s
            + self.trace_s
            + self.output_s
    }
}
