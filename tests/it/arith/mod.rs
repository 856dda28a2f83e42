//! The kernels' arithmetic on the GPU against its Rust twins: the intersection tests and the
//! BVH's node test (`intersection`, on the random cases of `cases`), and the tone mapping
//! (`tonemap`). Each runs a test kernel composed from `shaders/shared/` and compares every
//! answer with the twin's.

use glam::Vec3;

mod cases;
mod intersection;
mod tonemap;

/// A small xorshift generator: the cases are the same on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
    fn vec(&mut self, r: f32) -> Vec3 {
        Vec3::new(self.range(-r, r), self.range(-r, r), self.range(-r, r))
    }
    fn dir(&mut self) -> Vec3 {
        loop {
            let v = self.vec(1.0);
            if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
    fn pick<T: Copy>(&mut self, v: &[T]) -> T {
        v[(self.next() % v.len() as u64) as usize]
    }
}
