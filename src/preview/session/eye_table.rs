//! The eye's table of a moved camera, rebuilt on a worker thread once the camera rests and
//! swapped in at a pass boundary while it still matches the camera (a build for an older
//! camera goes back for another rebuild); until then the session traces with the BVH.

use std::sync::mpsc::{self, Receiver, TryRecvError};
use std::time::Duration;

use super::{make_room_for_moves, Session};
use crate::coherence::{BuildParams, FlatTables, Tables};
use crate::error::{Error, Result};
use crate::gpu::prepare::{self, add_surface_walk, Purpose};
use crate::gpu::shaders::Accel;
use crate::job::RenderOptions;
use crate::scene::Scene;

/// How long the camera rests before the eye's table is rebuilt for it.
const REST_BEFORE_REBUILD: Duration = Duration::from_millis(100);

/// An eye-table rebuild running on a worker thread for camera change `generation`.
pub(super) struct EyeBuild {
    generation: u64,
    result: Receiver<Result<Tables>>,
}

/// What the preview's eye table is doing, for the title and the frame log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EyeTable {
    /// Rebuilding for a moved camera; the BVH traces meanwhile.
    Building,
    /// The tables trace.
    Ready,
    /// The session traces without tables (`--accel bvh` or `brute`, or a failed rebuild).
    None,
}

impl EyeTable {
    pub fn name(self) -> &'static str {
        match self {
            EyeTable::Building => "building",
            EyeTable::Ready => "ready",
            EyeTable::None => "none",
        }
    }
}

/// The build parameters of the session's tables (`opts` resolved): every effect the scene
/// has, at any depth, so that toggling one back on or deepening the trees needs no new table.
fn eye_build_params(scene: &Scene, opts: &RenderOptions) -> BuildParams {
    let opts = RenderOptions { accel: Accel::Cube, ..opts.clone() };
    prepare::tables_of(scene, &opts, Purpose::Preview { effects: scene.effects() })
        .expect("the tables serve the session's every effect")
}

/// Gives the candidate list of `flat` room after its end (a quarter more, within the
/// adapter's binding limit), so that the eye's table rebuilt for another camera, whose list
/// may come out longer, is written into the same buffer. The walks never read past a
/// cell's own entries.
pub(super) fn make_room_for_eye_tables(flat: &mut FlatTables, max_binding: u64) {
    let entry = std::mem::size_of::<crate::coherence::flat::GpuEntry>() as u64;
    let most = (max_binding / entry) as usize;
    let len = flat.entries.len();
    flat.entries.resize((len + len / 4 + 64).min(most).max(len), Default::default());
}

impl Session {
    /// What the eye's table is doing.
    pub fn eye_table(&self) -> EyeTable {
        if self.eye_build.is_some()
            || self.eye_ready.is_some()
            || (self.wants_tables && self.accel != Accel::Cube)
        {
            EyeTable::Building
        } else if self.accel == Accel::Cube {
            EyeTable::Ready
        } else {
            EyeTable::None
        }
    }

    /// Rebuilds the eye's table of `tables` for the current camera on a worker thread.
    fn start_eye_build(&mut self, mut tables: Tables) {
        let generation = self.camera_generation;
        // The tables never read the textures: the worker gets the scene without them.
        let textures = std::mem::take(&mut self.scene.textures);
        let scene = self.scene.clone();
        self.scene.textures = textures;
        let opts = self.opts.clone();
        let (send, result) = mpsc::channel();
        let spawned = std::thread::Builder::new().name("eye table".into()).spawn(move || {
            let params = eye_build_params(&scene, &opts);
            let built = tables.rebuild_eye(&scene, &params).map(|eye_only| {
                log::debug!(
                    "eye table for camera change {generation} in {:.3} s (eye table only: {eye_only})",
                    tables.build_s
                );
                tables
            });
            let _ = send.send(built);
        });
        match spawned {
            Ok(_) => self.eye_build = Some(EyeBuild { generation, result }),
            Err(e) => {
                log::error!("cannot start the eye table's worker ({e}): tracing with the BVH");
                self.wants_tables = false;
            }
        }
    }

    /// Takes a finished eye-table build: tables for the current camera are swapped in at
    /// the next pass boundary, tables for an older camera go back for another rebuild.
    pub(super) fn poll_eye_table(&mut self, force: bool) -> Result<()> {
        let resting = force || self.last_move.elapsed() >= REST_BEFORE_REBUILD;
        if self.wants_tables && self.eye_build.is_none() && self.accel != Accel::Cube && resting {
            // The camera rests (this runs between its frames' passes, not while it moves,
            // and once it has rested a while: a build a drag overtakes cannot be stopped
            // and takes a core from the kernels): the eye's table is rebuilt for it.
            if let Some(tables) = self.tables.take() {
                self.start_eye_build(tables);
            }
        }
        if let Some(build) = &self.eye_build {
            let built = match build.result.try_recv() {
                Ok(built) => Some(built),
                Err(TryRecvError::Empty) => None,
                Err(TryRecvError::Disconnected) => {
                    Some(Err(Error::Scene("the eye table's worker stopped without a result".into())))
                }
            };
            if let Some(built) = built {
                let generation = build.generation;
                self.take_build(generation, built);
            }
        }
        if self.eye_ready.is_some() && self.schedule.at_pass_start() {
            let mut tables = self.eye_ready.take().expect("checked");
            let mut packed = self.pack_moved();
            packed.params.point_at_tables(&tables.flat);
            // The preview's rays leaving surfaces walk the BVH: its boxes move with the
            // camera in place, where the driver's structure would be built anew.
            add_surface_walk(&mut packed, &self.scene, &eye_build_params(&self.scene, &self.opts), false);
            make_room_for_moves(&mut packed, &self.scene);
            if let Err(e) = self.install(Accel::Cube, packed, Some(&mut tables)) {
                log::warn!("cannot trace the rebuilt tables ({e}): tracing with the BVH");
                self.wants_tables = false;
            }
            self.tables = Some(tables);
        }
        Ok(())
    }

    /// The end of the eye-table build for camera change `generation`: tables for the
    /// current camera wait for a pass boundary, older ones go back for another rebuild, and
    /// a failed rebuild leaves the session on the BVH.
    fn take_build(&mut self, generation: u64, built: Result<Tables>) {
        self.eye_build = None;
        match built {
            Ok(tables) if generation == self.camera_generation => self.eye_ready = Some(tables),
            // The camera moved on: rebuilt again once it rests (`poll_eye_table`).
            Ok(tables) => self.tables = Some(tables),
            Err(e) => {
                log::warn!("cannot rebuild the candidate tables: {e}; tracing with the BVH");
                self.wants_tables = false;
            }
        }
    }

    /// Waits for the eye table's rebuild, if one runs, and traces with the tables from the
    /// next pass boundary on (tests, and a preview about to exit).
    pub fn wait_for_eye_table(&mut self) -> Result<()> {
        loop {
            self.poll_eye_table(true)?;
            let Some(build) = &self.eye_build else { return Ok(()) };
            let built = build
                .result
                .recv()
                .map_err(|_| Error::Scene("the eye table's worker stopped without a result".into()));
            let generation = build.generation;
            self.take_build(generation, built.and_then(|b| b));
        }
    }
}
