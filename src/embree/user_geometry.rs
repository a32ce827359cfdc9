//! Embree user geometry from a Rust primitive set: bounds, intersect and occluded callbacks
//! for any packet width N, with filter invocation as in Embree's user_geometry tutorial.
//!
//! A [`UserPrimitives`] implementation supplies per-primitive bounds and a ray test in Rust;
//! this module owns the FFI: it reads rays from Embree's SOA layout, calls the test, and for
//! each candidate hit copies the instance ID stack, sets `tfar`, invokes the user's filter
//! functions, and accepts or restores. No panic crosses into Embree: every callback body runs
//! in `catch_unwind`, and the panic is resumed in the Rust caller of the query, or reported by
//! `commit` (see `src/embree/panic.rs`).

use std::cell::Cell;
use std::ffi::c_void;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use glam::Vec3;

use super::device::{EmbreeError, MAX_INSTANCE_LEVEL_COUNT};
use super::panic::{self, PanicRecord};
use super::scene::{
    query_flags, rayhit8, valid8, CommittedScene, GeometryOptions, Hit, OccludedArgs, OwnedGeometry,
    QueryContext, Ray, Scene, PACKET8,
};
use crate::sys;

/// A hit on one primitive, in the primitive's own space (instances are Embree's business).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimHit {
    /// The ray parameter of the hit.
    pub t: f32,
    /// The barycentric of the primitive's second vertex.
    pub u: f32,
    /// The barycentric of the primitive's third vertex.
    pub v: f32,
    /// Geometric normal (any length, oriented like Embree's triangles: `dp/du x dp/dv`).
    pub ng: Vec3,
    /// The primID Embree reports: the primitive tested, or (for a primitive that groups
    /// several, as [`crate::embree::PhongMesh`]'s clusters of patches) the member hit.
    pub prim: u32,
}

/// The point of this geometry an occlusion ray starts on, as the occluded callback hands it to
/// [`UserPrimitives::intersect_from`]: the member hit (a [`PrimHit::prim`]) and its `(u, v)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OriginPrim {
    /// The member the ray starts on, as its hit reported it ([`PrimHit::prim`]).
    pub prim: u32,
    /// The barycentric `u` of the start point on it.
    pub u: f32,
    /// The barycentric `v` of the start point on it.
    pub v: f32,
}

/// Where an occlusion ray starts, for [`CommittedScene::occluded1_from`] and [`CommittedScene::occluded8_rays_from`]:
/// the hit it leaves from (geometry, primitive, `(u, v)` and instance stack, as [`Hit`] reports
/// them). A user geometry may then leave out the primitive the ray starts on where it proves the
/// ray cannot meet it again ([`UserPrimitives::intersect_from`]); the answer is the same.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayOrigin {
    /// The geometry's ID in the scene that holds it.
    pub geom_id: u32,
    /// The primitive (for a user geometry, the member hit: [`PrimHit::prim`]).
    pub prim: u32,
    /// The barycentric `u` of the start point.
    pub u: f32,
    /// The barycentric `v` of the start point.
    pub v: f32,
    /// The instance IDs from the outermost level, `u32::MAX` where unused (as [`Hit::inst_id`]).
    pub inst_id: [u32; MAX_INSTANCE_LEVEL_COUNT],
}

impl RayOrigin {
    /// The origin of a ray leaving the point `hit` found.
    pub fn of_hit(hit: &Hit) -> Self {
        RayOrigin { geom_id: hit.geom_id, prim: hit.prim_id, u: hit.u, v: hit.v, inst_id: hit.inst_id }
    }
}

/// A set of primitives that Embree can bound and intersect through callbacks.
pub trait UserPrimitives: Send + Sync + 'static {
    /// Number of primitives (Embree's primitives are `0..count`; hits report [`PrimHit::prim`]).
    fn count(&self) -> u32;
    /// Conservative bounds of primitive `prim`, or `None` to exclude it from the BVH.
    fn bounds(&self, prim: u32) -> Option<(Vec3, Vec3)>;
    /// The nearest hit of `org + t dir` with `t` in the open interval `(tnear, tfar)`.
    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit>;
    /// [`UserPrimitives::intersect`] for an occlusion ray that starts on this geometry at
    /// `origin` ([`CommittedScene::occluded1_from`]): an implementation may leave out the member `origin`
    /// names where it proves the ray cannot meet it, and must otherwise answer as `intersect`.
    /// The default ignores the origin.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn intersect_from(
        &self,
        prim: u32,
        origin: Option<OriginPrim>,
        org: Vec3,
        dir: Vec3,
        tnear: f32,
        tfar: f32,
    ) -> Option<PrimHit> {
        let _ = origin;
        self.intersect(prim, org, dir, tnear, tfar)
    }

    /// [`UserPrimitives::intersect_from`] for every active lane of a packet meeting `prim`:
    /// lane `i`'s nearest hit in `hits[i]` (inactive lanes are left as they are). The packet
    /// callbacks (`rtcIntersect4/8/16`, `rtcOccluded4/8/16`) call this once per primitive; the
    /// default tests lane by lane, and an implementation may test the lanes together, with the
    /// same answers.
    #[inline]
    fn intersect_packet(&self, prim: u32, rays: &PacketRays, hits: &mut [Option<PrimHit>; MAX_PACKET]) {
        for lane in rays.active_lanes() {
            let (org, dir, tnear, tfar) = rays.ray(lane);
            hits[lane] = self.intersect_from(prim, rays.origin[lane], org, dir, tnear, tfar);
        }
    }
}

/// The widest packet Embree passes to the callbacks (`rtcIntersect16`).
pub const MAX_PACKET: usize = 16;

/// The rays of a packet as the packet callbacks hand them to
/// [`UserPrimitives::intersect_packet`]: lanes `0..n`, structure of arrays, `active[i]` where
/// Embree's valid mask has lane `i` (the other lanes' fields are zero).
#[derive(Clone, Copy, Debug)]
pub struct PacketRays {
    /// The packet's width (Embree's N).
    pub n: usize,
    /// Which lanes are to be tested.
    pub active: [bool; MAX_PACKET],
    /// The origins' x, y and z.
    pub org: [[f32; MAX_PACKET]; 3],
    /// The directions' x, y and z.
    pub dir: [[f32; MAX_PACKET]; 3],
    /// The open intervals' lower ends.
    pub tnear: [f32; MAX_PACKET],
    /// The open intervals' upper ends.
    pub tfar: [f32; MAX_PACKET],
    /// Where each lane's ray starts on this geometry, if known (occlusion rays of
    /// [`CommittedScene::occluded8_rays_from`]), as [`UserPrimitives::intersect_from`] takes it.
    pub origin: [Option<OriginPrim>; MAX_PACKET],
}

impl PacketRays {
    /// The indices of the active lanes, in order.
    pub fn active_lanes(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.n.min(MAX_PACKET)).filter(|&i| self.active[i])
    }

    /// Lane `i`'s ray: `(org, dir, tnear, tfar)`.
    pub fn ray(&self, i: usize) -> (Vec3, Vec3, f32, f32) {
        let (o, d) = (&self.org, &self.dir);
        (
            Vec3::new(o[0][i], o[1][i], o[2][i]),
            Vec3::new(d[0][i], d[1][i], d[2][i]),
            self.tnear[i],
            self.tfar[i],
        )
    }
}

/// Shared primitives: the scene holds one reference, the caller keeps others (for shading
/// queries on the same data, without a copy).
impl<T: UserPrimitives> UserPrimitives for Arc<T> {
    fn count(&self) -> u32 {
        (**self).count()
    }

    fn bounds(&self, prim: u32) -> Option<(Vec3, Vec3)> {
        (**self).bounds(prim)
    }

    #[inline]
    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        (**self).intersect(prim, org, dir, tnear, tfar)
    }

    #[inline]
    fn intersect_from(
        &self,
        prim: u32,
        origin: Option<OriginPrim>,
        org: Vec3,
        dir: Vec3,
        tnear: f32,
        tfar: f32,
    ) -> Option<PrimHit> {
        (**self).intersect_from(prim, origin, org, dir, tnear, tfar)
    }

    #[inline]
    fn intersect_packet(&self, prim: u32, rays: &PacketRays, hits: &mut [Option<PrimHit>; MAX_PACKET]) {
        (**self).intersect_packet(prim, rays, hits)
    }
}

/// What a user geometry's `geometryUserPtr` points to: the primitives and the record of
/// callback panics that no Rust caller was waiting for.
pub(crate) struct UserData<T> {
    pub(crate) prims: T,
    pub(crate) panics: Arc<PanicRecord>,
}

impl<T> UserData<T> {
    pub(crate) fn new(prims: T) -> Self {
        UserData { prims, panics: Arc::default() }
    }

    /// How many callback panics were recorded (not resumed in a Rust caller) so far.
    pub(crate) fn recorded_panics(&self) -> u64 {
        self.panics.count()
    }
}

// ---------------------------------------------------------------------------------------------
// SOA access. Embree's RTCRayN / RTCHitN of width N store field k of lane i at float index
// k*N + i (rtcore_ray.h: RTCRayN_org_x(ray,N,i) = ((float*)ray)[0*N+i], ...); the hit of an
// RTCRayHitN starts after the 12 ray fields (RTCRayHitN_HitN = &((float*)rayhit)[12*N]).

const RAY_ORG: usize = 0;
const RAY_TNEAR: usize = 3;
const RAY_DIR: usize = 4;
const RAY_TFAR: usize = 8;
const RAY_ID: usize = 10;
const RAY_FIELDS: usize = 12;
const HIT_NG: usize = 0;
const HIT_U: usize = 3;
const HIT_V: usize = 4;
const HIT_PRIM: usize = 5;
const HIT_GEOM: usize = 6;
const HIT_INST: usize = 7;
const HIT_INST_PRIM: usize = 7 + MAX_INSTANCE_LEVEL_COUNT;
const HIT_FIELDS: usize = 7 + 2 * MAX_INSTANCE_LEVEL_COUNT;

/// A raw SOA block of `n` lanes.
#[derive(Clone, Copy)]
struct Soa {
    base: *mut u32,
    n: usize,
}

impl Soa {
    /// # Safety
    /// `base` must point to at least `fields * n` 4-byte values valid for reads and writes.
    unsafe fn f(&self, field: usize, lane: usize) -> f32 {
        // SAFETY: in bounds by this function's contract.
        f32::from_bits(unsafe { self.base.add(field * self.n + lane).read() })
    }
    /// # Safety
    /// As for [`Soa::f`].
    unsafe fn set_f(&self, field: usize, lane: usize, x: f32) {
        // SAFETY: in bounds by this function's contract.
        unsafe { self.base.add(field * self.n + lane).write(x.to_bits()) }
    }
    /// # Safety
    /// As for [`Soa::f`].
    unsafe fn u(&self, field: usize, lane: usize) -> u32 {
        // SAFETY: in bounds by this function's contract.
        unsafe { self.base.add(field * self.n + lane).read() }
    }
    /// # Safety
    /// As for [`Soa::f`].
    unsafe fn set_u(&self, field: usize, lane: usize, x: u32) {
        // SAFETY: in bounds by this function's contract.
        unsafe { self.base.add(field * self.n + lane).write(x) }
    }
}

struct LaneRay {
    org: Vec3,
    dir: Vec3,
    tnear: f32,
    tfar: f32,
}

/// # Safety
/// `ray` must be an RTCRayN of width `ray.n` and `lane < ray.n`.
unsafe fn read_ray(ray: Soa, lane: usize) -> LaneRay {
    // SAFETY: the ray fields are among the 12 of an RTCRayN of width n, lane < n (contract).
    unsafe {
        LaneRay {
            org: Vec3::new(ray.f(RAY_ORG, lane), ray.f(RAY_ORG + 1, lane), ray.f(RAY_ORG + 2, lane)),
            dir: Vec3::new(ray.f(RAY_DIR, lane), ray.f(RAY_DIR + 1, lane), ray.f(RAY_DIR + 2, lane)),
            tnear: ray.f(RAY_TNEAR, lane),
            tfar: ray.f(RAY_TFAR, lane),
        }
    }
}

/// # Safety
/// `hit` must be an RTCHitN of width `hit.n`, `lane < hit.n`, `context` a valid query context.
unsafe fn write_hit(
    hit: Soa,
    lane: usize,
    h: &PrimHit,
    prim: u32,
    geom: u32,
    context: *const sys::RTCRayQueryContext,
) {
    // SAFETY: every field written is one of the HIT_FIELDS of an RTCHitN of width n, lane < n,
    // and `context` is a valid query context (this function's contract).
    unsafe {
        hit.set_f(HIT_NG, lane, h.ng.x);
        hit.set_f(HIT_NG + 1, lane, h.ng.y);
        hit.set_f(HIT_NG + 2, lane, h.ng.z);
        hit.set_f(HIT_U, lane, h.u);
        hit.set_f(HIT_V, lane, h.v);
        hit.set_u(HIT_PRIM, lane, prim);
        hit.set_u(HIT_GEOM, lane, geom);
        let ctx = &*context;
        for l in 0..MAX_INSTANCE_LEVEL_COUNT {
            hit.set_u(HIT_INST + l, lane, ctx.instID[l]);
            hit.set_u(HIT_INST_PRIM + l, lane, ctx.instPrimID[l]);
        }
    }
}

/// Hits refused because their `t` was outside the ray's `(tnear, tfar)`.
static OUT_OF_RANGE: AtomicU64 = AtomicU64::new(0);

/// How many hits [`UserPrimitives::intersect`] implementations returned, in this process so
/// far, with `t` outside the open interval `(tnear, tfar)` they were asked about (or NaN): each
/// was refused (the ray saw no hit from that call) and counted here. A correct implementation
/// never adds to it.
pub fn user_hits_out_of_range() -> u64 {
    OUT_OF_RANGE.load(Ordering::Relaxed)
}

/// The most candidate hits offered to the filters per primitive and lane.
const MAX_CANDIDATES: usize = 32;

/// The largest packet Embree passes (rtcIntersect16).
const MAX_N: usize = MAX_PACKET;

/// Per-lane valid mask with only `lane` active, for invoking filters on one candidate.
fn lane_mask(n: usize, lane: usize) -> [i32; MAX_N] {
    let mut m = [0i32; MAX_N];
    if lane < n {
        m[lane] = -1;
    }
    m
}

// ---------------------------------------------------------------------------------------------
// Callbacks.

unsafe extern "C" fn bounds_callback<T: UserPrimitives>(args: *const sys::RTCBoundsFunctionArguments) {
    // SAFETY: Embree passes valid arguments whose geometryUserPtr is the pointer we set with
    // rtcSetGeometryUserData: a `UserData<T>` kept alive by the scene (the bounds callback's own
    // userPtr is ignored by Embree 4, so we never rely on it); bounds_o points to one writable
    // RTCBounds (rtcSetGeometryBoundsFunction docs).
    let (data, out, prim) = unsafe {
        let args = &*args;
        (&*(args.geometryUserPtr as *const UserData<T>), &mut *args.bounds_o, args.primID)
    };
    // Runs on Embree's build threads: a panic is recorded for `Scene::commit` to report.
    let b = panic::record_on_panic(&data.panics, "bounds", || data.prims.bounds(prim));
    match b.flatten() {
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() && lo.cmple(hi).all() => {
            (out.lower_x, out.lower_y, out.lower_z) = (lo.x, lo.y, lo.z);
            (out.upper_x, out.upper_y, out.upper_z) = (hi.x, hi.y, hi.z);
        }
        _ => {
            // Excluded (or panicked): empty bounds (lower > upper), which Embree's builders skip.
            (out.lower_x, out.lower_y, out.lower_z) = (f32::INFINITY, f32::INFINITY, f32::INFINITY);
            (out.upper_x, out.upper_y, out.upper_z) =
                (f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY);
        }
    }
}

unsafe extern "C" fn intersect_callback<T: UserPrimitives>(args: *const sys::RTCIntersectFunctionNArguments) {
    // SAFETY: Embree passes valid arguments for N lanes: `valid` has N ints, `rayhit` is an
    // RTCRayHitN of width N, `context` is the query's context, and geometryUserPtr is our
    // `UserData<T>` (rtcSetGeometryIntersectFunction docs), alive while the scene is.
    let a = unsafe { &*args };
    // SAFETY: as above.
    let data = unsafe { &*(a.geometryUserPtr as *const UserData<T>) };
    panic::wrap(&data.panics, "intersect", || {
        // One lane (rtcIntersect1, what the renderer calls) gets its own copy with the width a
        // constant, so the SOA indexing and the lane loop fold away.
        match a.N as usize {
            // SAFETY: `a` is the argument block Embree passed, with its own N.
            1 => unsafe { intersect_lanes::<T>(args, a, &data.prims, 1) },
            // SAFETY: as above.
            n @ 2..=MAX_N => unsafe { intersect_lanes::<T>(args, a, &data.prims, n) },
            _ => {}
        }
    });
}

/// Offer each active lane's candidate hits on `prim`, nearest first, to `offer(lane, ray, hit)`,
/// which returns whether the filters accepted it. A primitive can be crossed several times:
/// after a rejected candidate, look beyond it (at most [`MAX_CANDIDATES`]: 4 roots for each of
/// a cluster's 8 patches, the resultant of a line and a quadratic patch being a quartic). A
/// rejection restores the lane's `tfar`, so its value read here holds. `origin(lane)` is where
/// the lane's ray starts on this geometry, if known (occlusion rays of [`CommittedScene::occluded1_from`]).
/// One lane is tested alone; a packet's first candidates come from
/// [`UserPrimitives::intersect_packet`], all its lanes (and their origins) at once.
///
/// # Safety
/// `ray` must be an RTCRayN (or the ray part of an RTCRayHitN) of width `valid.len()`.
#[inline(always)]
unsafe fn for_each_candidate<T: UserPrimitives>(
    data: &T,
    prim: u32,
    valid: &[i32],
    ray: Soa,
    origin: impl Fn(usize) -> Option<OriginPrim>,
    mut offer: impl FnMut(usize, &LaneRay, &PrimHit) -> bool,
) {
    if valid.len() == 1 {
        if valid[0] == -1 {
            // SAFETY: lane 0 < n = 1 of an RTCRayN (this function's contract).
            let r = unsafe { read_ray(ray, 0) };
            let from = origin(0);
            let first = data.intersect_from(prim, from, r.org, r.dir, r.tnear, r.tfar);
            offer_candidates(data, prim, 0, from, &r, first, &mut offer);
        }
        return;
    }
    // SAFETY: the layout is RTCRayN of width valid.len() (this function's contract).
    let mut rays = unsafe { read_packet(ray, valid) };
    for lane in 0..rays.n {
        if rays.active[lane] {
            rays.origin[lane] = origin(lane);
        }
    }
    let mut hits = [None; MAX_N];
    data.intersect_packet(prim, &rays, &mut hits);
    for lane in rays.active_lanes() {
        let (org, dir, tnear, tfar) = rays.ray(lane);
        let r = LaneRay { org, dir, tnear, tfar };
        offer_candidates(data, prim, lane, rays.origin[lane], &r, hits[lane], &mut offer);
    }
}

/// Offer `first`, lane `lane`'s nearest hit on `prim`, then (while the filters reject) the
/// next ones beyond it, as [`for_each_candidate`] describes.
#[inline(always)]
fn offer_candidates<T: UserPrimitives>(
    data: &T,
    prim: u32,
    lane: usize,
    from: Option<OriginPrim>,
    r: &LaneRay,
    first: Option<PrimHit>,
    offer: &mut impl FnMut(usize, &LaneRay, &PrimHit) -> bool,
) {
    let (mut next, mut tnear) = (first, r.tnear);
    for _ in 0..MAX_CANDIDATES {
        let Some(h) = next else { break };
        // Embree takes the hit's t as the ray's new tfar: one outside the interval asked for
        // (or NaN) would be a hit behind the origin or past a nearer one. Refused, and counted
        // ([`user_hits_out_of_range`]).
        if !(h.t > tnear && h.t < r.tfar) {
            OUT_OF_RANGE.fetch_add(1, Ordering::Relaxed);
            break;
        }
        if offer(lane, r, &h) {
            break;
        }
        tnear = h.t;
        next = data.intersect_from(prim, from, r.org, r.dir, h.t, r.tfar);
    }
}

/// The rays of a packet of width `valid.len()` (at most [`MAX_N`]), the lanes `valid` marks
/// active (Embree's `-1`).
///
/// # Safety
/// `ray` must be an RTCRayN of width `valid.len()`.
unsafe fn read_packet(ray: Soa, valid: &[i32]) -> PacketRays {
    let n = valid.len().min(MAX_N);
    let mut p = PacketRays {
        n,
        active: [false; MAX_N],
        org: [[0.0; MAX_N]; 3],
        dir: [[0.0; MAX_N]; 3],
        tnear: [0.0; MAX_N],
        tfar: [0.0; MAX_N],
        origin: [None; MAX_N],
    };
    for (lane, _) in valid.iter().enumerate().take(n).filter(|(_, &v)| v == -1) {
        // SAFETY: lane < n and the layout is RTCRayN of width n (this function's contract).
        let r = unsafe { read_ray(ray, lane) };
        p.active[lane] = true;
        (p.org[0][lane], p.org[1][lane], p.org[2][lane]) = (r.org.x, r.org.y, r.org.z);
        (p.dir[0][lane], p.dir[1][lane], p.dir[2][lane]) = (r.dir.x, r.dir.y, r.dir.z);
        (p.tnear[lane], p.tfar[lane]) = (r.tnear, r.tfar);
    }
    p
}

/// The body of [`intersect_callback`] for packet width `n`.
///
/// # Safety
/// `a` is `*args`, valid arguments from Embree with `a.N == n` and `1 <= n <= MAX_N`, and
/// `data` the primitives its geometryUserPtr holds.
#[inline(always)]
unsafe fn intersect_lanes<T: UserPrimitives>(
    args: *const sys::RTCIntersectFunctionNArguments,
    a: &sys::RTCIntersectFunctionNArguments,
    data: &T,
    n: usize,
) {
    // SAFETY: `valid` points to N ints (Embree's RTCIntersectFunctionNArguments contract).
    let valid = unsafe { std::slice::from_raw_parts(a.valid, n) };
    let ray = Soa { base: a.rayhit as *mut u32, n };
    // SAFETY: the hit part of an RTCRayHitN starts after the 12 ray fields (rtcore_ray.h).
    let hit = Soa { base: unsafe { ray.base.add(RAY_FIELDS * n) }, n };
    let offer = |lane: usize, r: &LaneRay, h: &PrimHit| {
        // SAFETY: lane < n in an RTCRayHitN of width n; we save every field we overwrite to
        // restore on rejection.
        unsafe {
            let saved: [u32; HIT_FIELDS] = std::array::from_fn(|k| hit.u(k, lane));
            ray.set_f(RAY_TFAR, lane, h.t);
            write_hit(hit, lane, h, h.prim, a.geomID, a.context);
            let mut mask = lane_mask(n, lane);
            let fargs = sys::RTCFilterFunctionNArguments {
                valid: mask.as_mut_ptr(),
                geometryUserPtr: a.geometryUserPtr,
                context: a.context,
                ray: a.rayhit as *mut sys::RTCRayN,
                hit: hit.base as *mut sys::RTCHitN,
                N: a.N,
            };
            // `fargs` describes this very ray-hit packet with one lane active; Embree calls
            // the geometry's and the arguments' filters, which may clear the lane
            // (rtcInvokeIntersectFilterFromGeometry docs).
            sys::rtcInvokeIntersectFilterFromGeometry(args, &fargs);
            if mask[lane] == -1 {
                return true; // accepted
            }
            for (k, s) in saved.iter().enumerate() {
                hit.set_u(k, lane, *s);
            }
            ray.set_f(RAY_TFAR, lane, r.tfar);
            false
        }
    };
    // SAFETY: `ray` is the ray part of the packet Embree passed, of width n.
    unsafe { for_each_candidate(data, a.primID, valid, ray, |_| None, offer) }
}

/// A stack RTCHitN of up to 16 lanes with the alignment Embree's packet types use.
#[repr(C, align(64))]
struct HitBuf([u32; HIT_FIELDS * MAX_N]);

unsafe extern "C" fn occluded_callback<T: UserPrimitives>(args: *const sys::RTCOccludedFunctionNArguments) {
    // SAFETY: as in `intersect_callback`, with `ray` an RTCRayN of width N
    // (rtcSetGeometryOccludedFunction docs).
    let a = unsafe { &*args };
    // SAFETY: as above.
    let data = unsafe { &*(a.geometryUserPtr as *const UserData<T>) };
    panic::wrap(&data.panics, "occluded", || {
        // One lane (rtcOccluded1) gets its own copy, as in `intersect_callback`.
        match a.N as usize {
            // SAFETY: `a` is the argument block Embree passed, with its own N.
            1 => unsafe { occluded_lanes::<T>(args, a, &data.prims, 1) },
            // SAFETY: as above.
            n @ 2..=MAX_N => unsafe { occluded_lanes::<T>(args, a, &data.prims, n) },
            _ => {}
        }
    });
}

/// The body of [`occluded_callback`] for packet width `n`.
///
/// # Safety
/// `a` is `*args`, valid arguments from Embree with `a.N == n` and `1 <= n <= MAX_N`, and
/// `data` the primitives its geometryUserPtr holds.
#[inline(always)]
unsafe fn occluded_lanes<T: UserPrimitives>(
    args: *const sys::RTCOccludedFunctionNArguments,
    a: &sys::RTCOccludedFunctionNArguments,
    data: &T,
    n: usize,
) {
    // SAFETY: `valid` points to N ints (RTCOccludedFunctionNArguments contract).
    let valid = unsafe { std::slice::from_raw_parts(a.valid, n) };
    let ray = Soa { base: a.ray as *mut u32, n };
    let origins = origin_context(a.context);
    let origin = |lane: usize| {
        // SAFETY: lane < n in an RTCRayN of width n; `origins` and `a.context` are live for the
        // query (see `origin_context`).
        unsafe { origin_of(origins?, a.context, a.geomID, ray.u(RAY_ID, lane)) }
    };
    // The filter's hit buffer, zeroed only once a candidate needs it (most calls find none).
    let mut buf: Option<HitBuf> = None;
    let offer = |lane: usize, r: &LaneRay, h: &PrimHit| {
        // Lazily: building the zeroed buffer is the cost being avoided.
        #[allow(clippy::unnecessary_lazy_evaluations)]
        let hit = Soa { base: buf.get_or_insert_with(|| HitBuf([0; HIT_FIELDS * MAX_N])).0.as_mut_ptr(), n };
        // SAFETY: `hit` is our own HIT_FIELDS x n buffer; the filter sees the candidate
        // there, with the ray's tfar set to it (restored unless accepted).
        unsafe {
            ray.set_f(RAY_TFAR, lane, h.t);
            write_hit(hit, lane, h, h.prim, a.geomID, a.context);
            let mut mask = lane_mask(n, lane);
            let fargs = sys::RTCFilterFunctionNArguments {
                valid: mask.as_mut_ptr(),
                geometryUserPtr: a.geometryUserPtr,
                context: a.context,
                ray: a.ray,
                hit: hit.base as *mut sys::RTCHitN,
                N: a.N,
            };
            // As in `intersect_lanes` (rtcInvokeOccludedFilterFromGeometry docs).
            sys::rtcInvokeOccludedFilterFromGeometry(args, &fargs);
            if mask[lane] == -1 {
                // Occluded: Embree's convention is tfar = -inf.
                ray.set_f(RAY_TFAR, lane, f32::NEG_INFINITY);
                return true;
            }
            ray.set_f(RAY_TFAR, lane, r.tfar);
            false
        }
    };
    // SAFETY: `ray` is the ray part of the packet Embree passed, of width n.
    unsafe { for_each_candidate(data, a.primID, valid, ray, origin, offer) }
}

// ---------------------------------------------------------------------------------------------
// Origin-aware occlusion: the query context extended with where each ray starts (Embree 4 passes
// the caller's `RTCRayQueryContext` pointer to the callbacks as is, so data may follow it: "the
// context can be extended", rtcInitRayQueryContext docs). A ray names its entry by its `id`
// (entry k + 1; 0: none), which Embree carries through traversal, instancing and packet splits
// unchanged. A callback reads past the raw context only when the context is the one this thread
// registered for the query it runs under.

/// A query context followed by the origins of the query's `N` rays.
#[repr(C)]
struct OriginContext<const N: usize> {
    /// What Embree sees (first, so a pointer to it is a pointer to the whole).
    base: QueryContext,
    /// Entry `k` for the rays with `id == k + 1`.
    origins: [RayOrigin; N],
}

/// The registered query context (as Embree sees it) and its origins.
type Registration = (*const sys::RTCRayQueryContext, *const [RayOrigin]);

thread_local! {
    /// The [`OriginContext`] of the origin-aware query running on this thread (null: none).
    static ORIGIN_CONTEXT: Cell<Registration> =
        const { Cell::new((std::ptr::null(), std::ptr::slice_from_raw_parts(std::ptr::null(), 0))) };
}

/// Restores the thread's registered [`OriginContext`] when a query ends, by return or unwind.
struct Registered(Registration);

impl Drop for Registered {
    fn drop(&mut self) {
        ORIGIN_CONTEXT.with(|c| c.set(self.0));
    }
}

impl<const N: usize> OriginContext<N> {
    fn new() -> Self {
        OriginContext { base: QueryContext::new(), origins: [NO_ORIGIN; N] }
    }

    /// Run the query `f(args)` with arguments whose context is `self`, registered as this
    /// thread's origin context while it runs.
    fn query<R>(&mut self, coherent: bool, f: impl FnOnce(&mut OccludedArgs<'_>) -> R) -> R {
        let p: *mut Self = self;
        // SAFETY: `p` points to `self`, borrowed exclusively for this call; the base and the
        // origins are disjoint fields, so the context borrow Embree writes through leaves the
        // origins to be read through `p` (origin_of).
        let (base, origins) =
            unsafe { (&mut (*p).base, std::ptr::addr_of!((*p).origins) as *const [RayOrigin]) };
        let raw: *const sys::RTCRayQueryContext = base.as_raw();
        let mut args = OccludedArgs::new().flags(query_flags(coherent)).context(base);
        let _outer = Registered(ORIGIN_CONTEXT.with(|c| c.replace((raw, origins))));
        f(&mut args)
    }
}

/// The registered origins, if `context` is the registered context.
#[inline(always)]
fn origin_context(context: *const sys::RTCRayQueryContext) -> Option<*const [RayOrigin]> {
    let (ours, origins) = ORIGIN_CONTEXT.with(Cell::get);
    (!ours.is_null() && ours == context).then_some(origins)
}

/// The origin of the ray with `id` when it starts on geometry `geom` at the instance level the
/// query is at now (the context's instance stack).
///
/// # Safety
/// `origins` must be the registered origins of the running query and `context` Embree's
/// pointer to its context.
#[inline(always)]
unsafe fn origin_of(
    origins: *const [RayOrigin],
    context: *const sys::RTCRayQueryContext,
    geom: u32,
    id: u32,
) -> Option<OriginPrim> {
    let k = (id as usize).checked_sub(1).filter(|&k| k < origins.len())?;
    // SAFETY: the origins are registered by `OriginContext::query` for the query this callback
    // runs under and live (on its caller's stack) until it returns, k is in bounds; Embree
    // writes only the instance stack of the base context, read through its own pointer.
    let (o, stack) = unsafe { ((origins as *const RayOrigin).add(k).read(), (*context).instID) };
    (o.geom_id == geom && o.inst_id == stack).then_some(OriginPrim { prim: o.prim, u: o.u, v: o.v })
}

/// A ray origin that matches no geometry (a ray with `id` 0 has none anyway).
const NO_ORIGIN: RayOrigin = RayOrigin {
    geom_id: u32::MAX,
    prim: u32::MAX,
    u: 0.0,
    v: 0.0,
    inst_id: [u32::MAX; MAX_INSTANCE_LEVEL_COUNT],
};

impl CommittedScene {
    /// [`CommittedScene::occluded1`] for a ray that starts at `origin` (the hit it leaves from): the same
    /// answer, with the primitive it starts on left out where its geometry proves the ray cannot
    /// meet it again (Phong patches: [`crate::phong::convexity::leaves_patch`]). `None` is
    /// `occluded1`.
    pub fn occluded1_from(&self, ray: Ray, origin: Option<RayOrigin>) -> bool {
        let mut ctx = OriginContext::<1>::new();
        let mut r = ray.to_sys();
        if let Some(o) = origin {
            ctx.origins[0] = o;
            r.id = 1;
        }
        ctx.query(false, |args| self.occluded1_raw(&mut r, Some(args)));
        r.tfar == f32::NEG_INFINITY
    }

    /// [`CommittedScene::occluded8_rays`] for rays that start at `origins[k]` (lane `k`), as
    /// [`CommittedScene::occluded1_from`] for one ray: the same answers.
    pub fn occluded8_rays_from(
        &self,
        rays: &[Ray; PACKET8],
        origins: &[Option<RayOrigin>; PACKET8],
        active: u8,
        coherent: bool,
    ) -> u8 {
        if active == 0 {
            return 0;
        }
        let mut ctx = OriginContext::<PACKET8>::new();
        let mut ray = rayhit8(rays).ray;
        for (k, o) in origins.iter().enumerate() {
            if let Some(o) = o {
                ctx.origins[k] = *o;
                ray.id[k] = k as u32 + 1;
            }
        }
        ctx.query(coherent, |args| self.occluded8(&valid8(active), &mut ray, Some(args)));
        (0..PACKET8)
            .fold(0, |m, k| m | (((active & (1 << k) != 0 && ray.tfar[k] == f32::NEG_INFINITY) as u8) << k))
    }
}

/// The former name of [`GeometryOptions`], the one options type of every attach.
#[deprecated(since = "0.1.0", note = "use GeometryOptions, the one options type of every attach")]
pub type UserGeometryOptions = GeometryOptions;

/// Create a committed user geometry for `data` on `device_raw`. The caller must keep `data`
/// at its address for as long as the geometry can be traced.
///
/// # Safety
/// `device_raw` must be a live Embree device, and `data` must stay valid and unmoved until the
/// geometry and every scene it is attached to are released.
pub(crate) unsafe fn new_user_geometry<T: UserPrimitives>(
    device_raw: sys::RTCDevice,
    data: *const UserData<T>,
    options: GeometryOptions,
) -> sys::RTCGeometry {
    // SAFETY: the caller guarantees the device and data; the callbacks are monomorphised for
    // `T` and only ever cast geometryUserPtr back to `UserData<T>`; a null geometry (error
    // recorded on the device) is returned as is (rtcNewGeometry docs).
    unsafe {
        let geom = sys::rtcNewGeometry(device_raw, sys::RTCGeometryType::RTC_GEOMETRY_TYPE_USER);
        if geom.is_null() {
            return geom;
        }
        sys::rtcSetGeometryUserPrimitiveCount(geom, (*data).prims.count());
        sys::rtcSetGeometryUserData(geom, data as *mut c_void);
        sys::rtcSetGeometryBoundsFunction(geom, Some(bounds_callback::<T>), std::ptr::null_mut());
        sys::rtcSetGeometryIntersectFunction(geom, Some(intersect_callback::<T>));
        sys::rtcSetGeometryOccludedFunction(geom, Some(occluded_callback::<T>));
        sys::rtcSetGeometryMask(geom, options.mask);
        sys::rtcCommitGeometry(geom);
        geom
    }
}

impl Scene {
    /// Attach `prims` as one user geometry (one Embree primitive per element); the scene owns
    /// the data from now on. Returns the geomID.
    ///
    /// A panic in `prims`' callbacks never unwinds into Embree: under this crate's queries it
    /// is resumed in the caller once Embree returns; in `bounds` (run by [`Scene::commit`] on
    /// Embree's build threads) it makes `commit` return [`EmbreeError::CallbackPanicked`].
    pub fn attach_user<T: UserPrimitives>(
        &mut self,
        prims: T,
        options: GeometryOptions,
    ) -> Result<u32, EmbreeError> {
        let boxed = Box::new(UserData::new(prims));
        let ptr: *const UserData<T> = &*boxed;
        let record = boxed.panics.clone();
        let device = self.device().clone();
        // Hand the box to the scene first: its heap address stays put when the box moves.
        self.keep_alive(boxed);
        // The geometry's setters return nothing: `call` reads the errors they record, and a
        // geometry made before one failed is released with the `OwnedGeometry`.
        let geom = device.call(|| {
            let raw = {
                let _device = device.lock();
                // SAFETY: the device is live and locked; `ptr` points into the box the scene now
                // owns, released only after the scene (and so the geometry) is (SceneHandle
                // field order).
                unsafe { new_user_geometry(device.raw(), ptr, options) }
            };
            OwnedGeometry::new(&device, raw, "user geometry")
        })??;
        let id = self.attach_raw(geom)?;
        self.watch_panics(id, record);
        Ok(id)
    }
}

/// Flat triangles as a user geometry with a plain Möller–Trumbore triangle test:
/// the floor of what the callback route costs, and a check of the callback plumbing.
pub struct UserTriangles {
    /// The vertex positions.
    pub positions: Vec<Vec3>,
    /// Three vertex indices per triangle.
    pub indices: Vec<[u32; 3]>,
}

impl UserPrimitives for UserTriangles {
    fn count(&self) -> u32 {
        self.indices.len() as u32
    }

    fn bounds(&self, prim: u32) -> Option<(Vec3, Vec3)> {
        let t = self.indices.get(prim as usize)?;
        let p = t.map(|i| self.positions.get(i as usize).copied());
        let (a, b, c) = (p[0]?, p[1]?, p[2]?);
        Some((a.min(b).min(c), a.max(b).max(c)))
    }

    // Inlined into the callback: out of line, the ray's vectors went through the stack and the
    // `primary_rays` floor measured 20% slower (criterion, back to back).
    #[inline(always)]
    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        let t = self.indices.get(prim as usize)?;
        let p = |k: usize| self.positions.get(t[k] as usize).copied();
        let (v0, v1, v2) = (p(0)?, p(1)?, p(2)?);
        // Möller–Trumbore: solve org + t dir = (1-u-v) v0 + u v1 + v v2.
        let (e1, e2) = (v1 - v0, v2 - v0);
        let pv = dir.cross(e2);
        let det = e1.dot(pv);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let s = org - v0;
        let u = s.dot(pv) * inv;
        let q = s.cross(e1);
        let v = dir.dot(q) * inv;
        if !(u >= 0.0 && v >= 0.0 && u + v <= 1.0) {
            return None;
        }
        let t = e2.dot(q) * inv;
        (t > tnear && t < tfar).then(|| PrimHit { t, u, v, ng: e1.cross(e2), prim })
    }
}
