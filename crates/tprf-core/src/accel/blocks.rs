//! The small-scene path: every triangle of the scene tested on every ray, eight lanes at
//! a time, in at most eight *blocks* found by a slab test of their bounds first.
//!
//! - Two triangles that share an edge and make a parallelogram (a wall, a box's side)
//!   take one lane: the lane tests the parallelogram, and a hit goes to the triangle on
//!   its side of the shared diagonal.
//! - Where the lanes fill one block, that block is tested on every ray. Else they may be
//!   grouped into blocks by surface area (the chance that a ray meets a box grows with
//!   its area), each found by a slab test first: each wall of a room its own block, the
//!   faces of a box on the floor one block. A closest-hit ray then tests about the one
//!   wall it hits and the boxes it passes, a shadow ray inside the room only the boxes it
//!   passes.

use glam::{Vec3, Vec3A};

#[cfg(target_arch = "x86_64")]
mod avx2;

/// Lanes per block, and blocks per scene at most: one AVX register per coordinate where
/// the CPU has AVX2 (detected at run time), two SSE or NEON registers elsewhere.
pub(super) const LANES: usize = 8;

/// Padding of a block's bounds, BVH-space units (the scene's diagonal is about 2^14
/// units, its coordinates' rounding at most 2^-10): 64 times the rounding of a
/// coordinate, far below a ray's offset from the surface it leaves.
const BLOCK_PAD: f32 = 1.0 / 16.0;

/// Eight lanes, one coordinate per array (lanes past the block's are zero: a zero
/// determinant, never hit). A lane is a triangle or a parallelogram with corner `v0`
/// and edges `e1`, `e2` (its points are `v0 + u e1 + v e2`): stored are `v0`, `e2`, the
/// reversed edge `ne1 = -e1`, the normal `n = e2 x e1` (not normalised), and `tri`: 1
/// for a triangle (`u + v <= 1`), 0 for a parallelogram (`u, v <= 1`).
#[derive(Clone, Copy, Debug, Default)]
struct Block {
    v0: [[f32; LANES]; 3],
    e2: [[f32; LANES]; 3],
    ne1: [[f32; LANES]; 3],
    n: [[f32; LANES]; 3],
    tri: [f32; LANES],
}

/// What a ray meets in one block: a bit mask of the lanes hit within (0, tmax), and per
/// lane the distance and `u`, `v` times the determinant's magnitude `det` (divided only
/// for the lanes hit: see [`BlockHits::lane`]).
struct BlockHits {
    mask: u32,
    t: [f32; LANES],
    u: [f32; LANES],
    v: [f32; LANES],
    det: [f32; LANES],
}

impl BlockHits {
    /// Lane `l`'s distance and `(u, v)`.
    #[inline(always)]
    fn lane(&self, l: usize) -> (f32, f32, f32) {
        let inv = 1.0 / self.det[l];
        (self.t[l] * inv, self.u[l] * inv, self.v[l] * inv)
    }
}

/// Eight flags, one per byte, to eight bits: the multiply gathers byte j's low bit into
/// bit 56 + j (no carries: each partial product lands on its own bit).
#[inline(always)]
fn mask_of(hit: [bool; LANES]) -> u32 {
    let bytes = u64::from_le_bytes(hit.map(u8::from));
    ((bytes.wrapping_mul(0x0102_0408_1020_4080)) >> 56) as u32
}

/// `a . b` with fused multiply-adds: `fma(a2, b2, fma(a1, b1, a0 b0))`.
#[inline(always)]
fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0]))
}

/// The eight lanes of a block against one ray, without branches, written for the
/// compiler to vectorise (the same IEEE operations on every instruction set, fused
/// multiply-adds included, so the same hits; where the CPU has no FMA, `mul_add` is
/// computed in software, slowly but exactly). Cramer's rule on `o + t d = v0 + u e1 +
/// v e2`, with `w = v0 - o` and `r = d x w`: `det = d . n`, `t det = w . n`,
/// `u det = r . e2`, `v det = r . ne1` (Moller-Trumbore's terms with the normal made
/// once per lane, and no division: the tests compare against `|det|`, the signs taken
/// from `det`).
#[inline(always)]
// One lane index reads thirteen arrays; the comparisons are joined with `&`, not
// ranges' short-circuiting `contains`, so every lane computes all of them.
#[allow(
    clippy::needless_range_loop,
    clippy::manual_range_contains,
    reason = "lane-wise comparisons joined with `&`, one index into thirteen arrays"
)]
fn intersect_block(b: &Block, o: Vec3A, d: Vec3A, tmax: f32) -> BlockHits {
    let mut out = BlockHits {
        mask: 0,
        t: [0.0; LANES],
        u: [0.0; LANES],
        v: [0.0; LANES],
        det: [0.0; LANES],
    };
    let mut hit = [false; LANES];
    for l in 0..LANES {
        let wx = b.v0[0][l] - o.x;
        let wy = b.v0[1][l] - o.y;
        let wz = b.v0[2][l] - o.z;
        let rx = d.y.mul_add(wz, -(d.z * wy));
        let ry = d.z.mul_add(wx, -(d.x * wz));
        let rz = d.x.mul_add(wy, -(d.y * wx));
        let (nx, ny, nz) = (b.n[0][l], b.n[1][l], b.n[2][l]);
        let det = dot3([d.x, d.y, d.z], [nx, ny, nz]);
        let sign = det.to_bits() & 0x8000_0000;
        let flip = |x: f32| f32::from_bits(x.to_bits() ^ sign);
        let t = flip(dot3([wx, wy, wz], [nx, ny, nz]));
        let u = flip(dot3([rx, ry, rz], [b.e2[0][l], b.e2[1][l], b.e2[2][l]]));
        let v = flip(dot3([rx, ry, rz], [b.ne1[0][l], b.ne1[1][l], b.ne1[2][l]]));
        let abs_det = det.abs();
        // A finite, non-zero determinant (NaN fails every comparison); a triangle's
        // third edge, or a parallelogram's two far edges.
        hit[l] = (abs_det > 0.0)
            & (abs_det < f32::INFINITY)
            & (u >= 0.0)
            & (v >= 0.0)
            & (v.mul_add(b.tri[l], u) <= abs_det)
            & (v <= abs_det)
            & (t > 0.0)
            & (t < tmax * abs_det);
        (out.t[l], out.u[l], out.v[l], out.det[l]) = (t, u, v, abs_det);
    }
    out.mask = mask_of(hit);
    out
}

/// The bounds of the blocks, one lane per block, padded by [`BLOCK_PAD`] so rounding in
/// the slab test never loses a hit the block's own test would find.
#[derive(Clone, Copy, Debug, Default)]
struct BlockBounds {
    lo: [[f32; LANES]; 3],
    hi: [[f32; LANES]; 3],
}

/// The slab test of a ray against every block's bounds: a mask of the blocks the segment
/// (0, `tmax`) meets, and where it enters each (0 where it starts inside). `inv_d` is
/// `1 / d` per axis (infinite for a zero component; the one NaN, a ray in a padded face's
/// plane, cannot enter the unpadded block, so either answer is right).
#[inline(always)]
#[allow(
    clippy::needless_range_loop,
    reason = "one lane index into several arrays"
)]
fn enter_blocks(b: &BlockBounds, o: Vec3A, inv_d: Vec3A, tmax: f32) -> (u32, [f32; LANES]) {
    let mut near_out = [0.0; LANES];
    let mut hit = [false; LANES];
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let max = |a: f32, b: f32| if a > b { a } else { b };
    for l in 0..LANES {
        let (mut near, mut far) = (0.0f32, tmax);
        for c in 0..3 {
            let t0 = (b.lo[c][l] - o[c]) * inv_d[c];
            let t1 = (b.hi[c][l] - o[c]) * inv_d[c];
            near = max(near, min(t0, t1));
            far = min(far, max(t0, t1));
        }
        hit[l] = near <= far;
        near_out[l] = near;
    }
    (mask_of(hit), near_out)
}

/// Which scene triangles a lane stands for, and how its `(u, v)` become a triangle's
/// barycentrics.
#[derive(Clone, Copy, Debug, Default)]
struct LaneTris {
    /// The triangle (`u + v <= 1`), and for a parallelogram the one beyond the diagonal.
    tri: [u32; 2],
    quad: bool,
    /// Per triangle, for its vertices 1 and 2: which of its three local weights belongs
    /// to them (see [`Blocks::resolve`]).
    slot: [[u8; 2]; 2],
}

/// A triangle of the scene for [`Blocks::build`]: its index and its vertices in world
/// space (to find parallelograms exactly) and in BVH space.
pub(super) struct SmallTri {
    pub index: u32,
    pub world: [Vec3; 3],
    pub bvh: [Vec3A; 3],
}

/// One lane before it has a block.
struct Prim {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
    tris: LaneTris,
    lo: Vec3A,
    hi: Vec3A,
}

/// A small scene's triangles in blocks.
pub(super) struct Blocks {
    blocks: Vec<Block>,
    bounds: BlockBounds,
    /// Per block and lane (`block * LANES + lane`).
    lanes: Vec<LaneTris>,
    triangles: usize,
    /// Whether a slab test of the blocks' bounds comes first (else every block is
    /// tested).
    cull: bool,
    /// Whether the blocks are tested with AVX2 and FMA (the CPU has them; never elsewhere).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(super) wide: bool,
}

/// Whether this CPU has AVX2 and FMA, for the eight-lane blocks.
pub(super) fn cpu_has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Surface area of the box `lo..hi`.
fn area(lo: Vec3A, hi: Vec3A) -> f32 {
    let e = (hi - lo).max(Vec3A::ZERO);
    2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
}

/// Where `a` and `b` make a parallelogram with a shared edge as its diagonal: `(k, i, j,
/// m, n, o)`, `a`'s vertex off the edge `k` and the edge's ends `i`, `j`, and where `b`
/// holds those ends (`m`, `n`) and its own vertex off the edge (`o`). Exact in world
/// space: the far corner is `a[i] + a[j] - a[k]`, bit for bit (sums in f64).
fn parallelogram(a: &[Vec3; 3], b: &[Vec3; 3]) -> Option<[usize; 6]> {
    for k in 0..3 {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let Some(m) = b.iter().position(|p| *p == a[i]) else {
            continue;
        };
        let Some(n) = b.iter().position(|p| *p == a[j]) else {
            continue;
        };
        let o = 3 - m - n;
        if m == n {
            continue;
        }
        let corner =
            (0..3).all(|c| a[k][c] as f64 + b[o][c] as f64 == a[i][c] as f64 + a[j][c] as f64);
        if corner {
            return Some([k, i, j, m, n, o]);
        }
    }
    None
}

/// Lanes and bounds of one block being formed.
type Group = (Vec<usize>, Vec3A, Vec3A);

/// `prims` grouped into blocks of at most `LANES`: from one lane per block, the two
/// blocks whose joined bounds add the least surface area are joined while that lowers
/// the total area, or there are more than `LANES` blocks, or (`fill`) while any two fit
/// together. `None` when more than `LANES` blocks remain.
fn group(prims: &[Prim], fill: bool) -> Option<Vec<Group>> {
    let mut groups: Vec<Group> = prims
        .iter()
        .enumerate()
        .map(|(i, p)| (vec![i], p.lo, p.hi))
        .collect();
    loop {
        let mut best: Option<(f32, usize, usize)> = None;
        for a in 0..groups.len() {
            for b in a + 1..groups.len() {
                let (ga, gb) = (&groups[a], &groups[b]);
                if ga.0.len() + gb.0.len() > LANES {
                    continue;
                }
                let joined = area(ga.1.min(gb.1), ga.2.max(gb.2));
                let cost = joined - area(ga.1, ga.2) - area(gb.1, gb.2);
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, a, b));
                }
            }
        }
        match best {
            Some((cost, a, b)) if fill || cost < 0.0 || groups.len() > LANES => {
                let gb = groups.remove(b);
                let ga = &mut groups[a];
                ga.0.extend(gb.0);
                ga.1 = ga.1.min(gb.1);
                ga.2 = ga.2.max(gb.2);
            }
            _ => break,
        }
    }
    (groups.len() <= LANES).then_some(groups)
}

impl Blocks {
    /// Lanes for `tris` (at most `LANES * LANES` once edge-sharing parallelograms are
    /// paired; the caller keeps scenes small), grouped into blocks (see [`group`]):
    /// culled blocks by area, or as few blocks as possible, all tested. Blocks are kept
    /// smallest area first, so a closest hit in a small block lets a ray skip a wall
    /// block behind it. `None` when the lanes do not fit.
    pub(super) fn build(tris: &[SmallTri]) -> Option<Blocks> {
        // Pair parallelograms, first come first paired.
        let mut paired = vec![false; tris.len()];
        let mut prims = Vec::new();
        for a in 0..tris.len() {
            if paired[a] {
                continue;
            }
            paired[a] = true;
            let ta = &tris[a];
            let partner = (a + 1..tris.len())
                .filter(|&b| !paired[b])
                .find_map(|b| parallelogram(&ta.world, &tris[b].world).map(|s| (b, s)));
            let (v0, e1, e2, lane) = match partner {
                Some((b, [k, i, j, m, n, o])) => {
                    paired[b] = true;
                    let (r, p, q) = (ta.bvh[k], ta.bvh[i], ta.bvh[j]);
                    // Local weights: triangle `a` (r, p, q), triangle `b` (p, q, s).
                    let mut slot = [[0u8; 2]; 2];
                    let local_a = |v: usize| [k, i, j].iter().position(|&x| x == v).unwrap_or(0);
                    let local_b = |v: usize| [m, n, o].iter().position(|&x| x == v).unwrap_or(0);
                    slot[0] = [local_a(1) as u8, local_a(2) as u8];
                    slot[1] = [local_b(1) as u8, local_b(2) as u8];
                    let lane = LaneTris {
                        tri: [ta.index, tris[b].index],
                        quad: true,
                        slot,
                    };
                    (r, p - r, q - r, lane)
                }
                None => {
                    let lane = LaneTris {
                        tri: [ta.index; 2],
                        quad: false,
                        slot: [[1, 2]; 2],
                    };
                    let [p0, p1, p2] = ta.bvh;
                    (p0, p1 - p0, p2 - p0, lane)
                }
            };
            let far = if lane.quad { v0 + e1 + e2 } else { v0 };
            let pts = [v0, v0 + e1, v0 + e2, far];
            let lo = pts.iter().fold(Vec3A::INFINITY, |m, p| m.min(*p)) - BLOCK_PAD;
            let hi = pts.iter().fold(Vec3A::NEG_INFINITY, |m, p| m.max(*p)) + BLOCK_PAD;
            prims.push(Prim {
                v0,
                e1,
                e2,
                tris: lane,
                lo,
                hi,
            });
        }
        // Culled blocks grouped by area, or as few blocks as the lanes fill, all tested on
        // every ray: whichever is expected to test fewer blocks per ray, counting the slab
        // test as one (measured: with culling, a ray's fixed cost is about one block's
        // test; the race's room, six parallelograms, renders 9 % faster in one unculled
        // block than culled in six, the Cornell box 2.4 % faster culled in seven than
        // unculled in three). A block's chance of being entered is taken as its area
        // over the scene's.
        let culled = group(&prims, false)?;
        let packed = group(&prims, true)?;
        let (lo, hi) = prims
            .iter()
            .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.lo), hi.max(p.hi))
            });
        let scene_area = area(lo, hi).max(f32::MIN_POSITIVE);
        let entered: f32 = culled.iter().map(|g| area(g.1, g.2) / scene_area).sum();
        let cull = culled.len() > 1 && 1.0 + entered < packed.len() as f32;
        let mut groups = if cull { culled } else { packed };
        groups.sort_by(|a, b| area(a.1, a.2).total_cmp(&area(b.1, b.2)));
        let mut blocks = vec![Block::default(); groups.len()];
        let mut bounds = BlockBounds::default();
        let mut lanes = vec![LaneTris::default(); groups.len() * LANES];
        for (k, (members, lo, hi)) in groups.iter().enumerate() {
            for c in 0..3 {
                bounds.lo[c][k] = lo[c];
                bounds.hi[c][k] = hi[c];
            }
            let b = &mut blocks[k];
            for (l, &i) in members.iter().enumerate() {
                let p = &prims[i];
                let n = p.e2.cross(p.e1);
                for c in 0..3 {
                    b.v0[c][l] = p.v0[c];
                    b.e2[c][l] = p.e2[c];
                    b.ne1[c][l] = -p.e1[c];
                    b.n[c][l] = n[c];
                }
                b.tri[l] = if p.tris.quad { 0.0 } else { 1.0 };
                lanes[k * LANES + l] = p.tris;
            }
        }
        Some(Blocks {
            blocks,
            bounds,
            lanes,
            triangles: tris.len(),
            cull,
            wide: cpu_has_avx2_fma(),
        })
    }

    /// Triangles the blocks hold.
    pub(super) fn triangles(&self) -> usize {
        self.triangles
    }

    /// Lane `id`'s hit at `(u, v)` as a scene triangle and its barycentrics (the
    /// weights of its vertices 1 and 2). A parallelogram `r + u (p - r) + v (q - r)`
    /// splits along `p q`: short of it, triangle `r p q` with weights `(1 - u - v, u,
    /// v)`; beyond it, triangle `p q s` (`s = p + q - r`) with `(1 - v, 1 - u, u + v -
    /// 1)`.
    #[inline]
    pub(super) fn resolve(&self, id: usize, u: f32, v: f32) -> Option<(u32, f32, f32)> {
        let lane = self.lanes.get(id)?;
        if !lane.quad {
            return Some((lane.tri[0], u, v));
        }
        let (t, w) = if u + v <= 1.0 {
            (0, [1.0 - u - v, u, v])
        } else {
            (1, [1.0 - v, 1.0 - u, u + v - 1.0])
        };
        let [s1, s2] = lane.slot[t];
        Some((lane.tri[t], w[s1 as usize], w[s2 as usize]))
    }

    /// Every hit of the ray within (0, `t_max`), block by block in the blocks' order and
    /// lane by lane, with AVX2 where the CPU has it: `visit(lane, t, u, v, t_max)` gets
    /// the lane's id (for [`Blocks::resolve`]), may lower `t_max` for the hits still to
    /// come, and returns whether to stop. Returns whether it stopped.
    #[inline]
    pub(super) fn hits(
        &self,
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        visit: impl FnMut(usize, f32, f32, f32, &mut f32) -> bool,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.wide {
            // SAFETY: `wide` is set only where the CPU was found to have AVX2 and FMA.
            return unsafe { self.hits_avx2(o, d, t_max, visit) };
        }
        self.hits_any(o, d, t_max, visit)
    }

    /// [`Blocks::hits`] in AVX2 intrinsics (`avx2.rs`): the same tests as
    /// [`Blocks::hits_any`], in the same order.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn hits_avx2(
        &self,
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        visit: impl FnMut(usize, f32, f32, f32, &mut f32) -> bool,
    ) -> bool {
        let ray = avx2::Ray8::new(o, d);
        let entered = self.entered(|| avx2::enter_blocks(&self.bounds, &ray, t_max));
        self.visit_blocks(
            entered,
            t_max,
            |b, t| avx2::intersect_block(b, &ray, t),
            visit,
        )
    }

    /// [`Blocks::hits`] for the instruction set it is compiled for. Out of line: callers
    /// inline [`Blocks::hits`], and the path they take on AVX2 machines stays one call.
    #[inline(never)]
    fn hits_any(
        &self,
        o: Vec3A,
        d: Vec3A,
        t_max: f32,
        visit: impl FnMut(usize, f32, f32, f32, &mut f32) -> bool,
    ) -> bool {
        let entered = self.entered(|| enter_blocks(&self.bounds, o, Vec3A::ONE / d, t_max));
        self.visit_blocks(entered, t_max, |b, t| intersect_block(b, o, d, t), visit)
    }

    /// The blocks a ray enters (a mask), and where it enters each: by `slab`, the slab
    /// test of their bounds, where the blocks are culled; else every block, from 0.
    #[inline(always)]
    fn entered(&self, slab: impl FnOnce() -> (u32, [f32; LANES])) -> (u32, [f32; LANES]) {
        let all = (1u32 << self.blocks.len()) - 1;
        if self.cull {
            let (entered, near) = slab();
            (entered & all, near)
        } else {
            (all, [0.0; LANES])
        }
    }

    /// The blocks `entered` (entered where `near` says) in order, each tested by
    /// `test(block, t_max)` unless the ray enters it past `t_max`, and their hits lane by
    /// lane handed to `visit` (see [`Blocks::hits`]).
    #[inline(always)]
    fn visit_blocks(
        &self,
        (mut entered, near): (u32, [f32; LANES]),
        mut t_max: f32,
        test: impl Fn(&Block, f32) -> BlockHits,
        mut visit: impl FnMut(usize, f32, f32, f32, &mut f32) -> bool,
    ) -> bool {
        while entered != 0 {
            let k = entered.trailing_zeros() as usize;
            entered &= entered - 1;
            let Some(b) = self.blocks.get(k) else { break };
            if near[k] > t_max {
                continue;
            }
            let h = test(b, t_max);
            let mut mask = h.mask;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let (t, u, v) = h.lane(lane);
                if visit(k * LANES + lane, t, u, v, &mut t_max) {
                    return true;
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blocks_of(scene: &crate::scene::Scene, keep: impl Fn(usize) -> bool) -> Blocks {
        let to_bvh = |p: Vec3| Vec3A::from(p) * 1024.0;
        let tris: Vec<SmallTri> = (0..scene.triangles.len())
            .filter(|&i| keep(i))
            .map(|i| {
                let p = scene.triangles[i].p;
                SmallTri {
                    index: i as u32,
                    world: p,
                    bvh: p.map(to_bvh),
                }
            })
            .collect();
        Blocks::build(&tris).unwrap()
    }

    /// Lanes in use per block, and whether each lane is a parallelogram.
    fn shape(b: &Blocks) -> Vec<Vec<bool>> {
        (0..b.blocks.len())
            .map(|k| {
                (0..LANES)
                    .filter(|&l| (0..3).any(|c| b.blocks[k].n[c][l] != 0.0))
                    .map(|l| b.lanes[k * LANES + l].quad)
                    .collect()
            })
            .collect()
    }

    /// The Cornell box: floor, ceiling and back wall (triangles 0-5), the two blocks
    /// (6-15, 16-25: four parallelogram sides and a top that is not one), the red and
    /// green walls (26-29).
    #[test]
    fn the_cornell_box_in_blocks() {
        let scene = crate::scene::load("builtin:cornell").unwrap();
        // Whole: 17 lanes; each block of the box, then each wall, culled.
        let all = blocks_of(&scene, |_| true);
        assert!(all.cull);
        let mut blocks = shape(&all);
        blocks.iter_mut().for_each(|b| b.sort());
        blocks.sort();
        let box_ = vec![false, false, true, true, true, true];
        let mut expected = vec![vec![true]; 5];
        expected.extend([box_.clone(), box_]);
        expected.sort();
        assert_eq!(blocks, expected);
        assert_eq!(all.triangles(), 30);
        // The walls alone: five parallelograms in one block, tested on every ray.
        let walls = blocks_of(&scene, |i| !(6..26).contains(&i));
        assert!(!walls.cull);
        assert_eq!(shape(&walls), vec![vec![true; 5]]);
    }
}
