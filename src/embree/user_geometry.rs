//! Embree user geometry from a Rust primitive set: bounds, intersect and occluded callbacks
//! for any packet width N, with filter invocation as in Embree's user_geometry tutorial.
//!
//! A [`UserPrimitives`] implementation supplies per-primitive bounds and a ray test in Rust;
//! this module owns the FFI: it reads rays from Embree's SOA layout, calls the test, and offers
//! each candidate hit to the geometry's filter in a hit packet of its own (with the instance ID
//! stack copied and `tfar` set to it), then copies it to the ray's hit if accepted or restores
//! `tfar` if not. No panic crosses into Embree: every callback body runs
//! in `catch_unwind`, and the panic is resumed in the Rust caller of the query, or reported by
//! `commit` (see `src/embree/panic.rs`).

use std::cell::Cell;
use std::ffi::c_void;
use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use glam::Vec3;

use super::device::{EmbreeError, MAX_INSTANCE_LEVEL_COUNT};
use super::panic::{self, PanicRecord};
use super::scene::{
    query_flags, rayhit8, valid8, CommittedScene, GeometryOptions, Hit, OccludedArgs, OwnedGeometry,
    QueryContext, Ray, Scene, PACKET8,
};
use crate::phong::intersect::{LaneRays, LANES};
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

/// A hit that occluded a ray of [`CommittedScene::occluded1_by`] or
/// [`CommittedScene::occluded8_rays_by`]: one the geometry's filters accepted, on a user
/// geometry of this crate, outside any instance. It is one of the ray's hits, not necessarily
/// the nearest (an occlusion query stops at the first it accepts).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blocker {
    /// The geometry's ID (as [`Hit::geom_id`]).
    pub geom_id: u32,
    /// The primitive (as [`Hit::prim_id`]).
    pub prim: u32,
    /// The hit's ray parameter.
    pub t: f32,
}

/// No [`Blocker`] recorded.
const NO_BLOCKER: Blocker = Blocker { geom_id: u32::MAX, prim: u32::MAX, t: f32::NAN };

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

    /// [`UserPrimitives::intersect_packet`] for a packet of [`LANES`] (`rtcIntersect8`,
    /// `rtcOccluded8`: the renderer's packets), as the packet callbacks read it: lane `i`'s
    /// nearest hit in the answer's `[i]`, `None` for a lane not `active`. The rays' inactive
    /// lanes are zero. Lane `i` starts on this geometry at `origin.get(i)`, looked up when
    /// asked (most tests need no lane's). The default goes through
    /// [`UserPrimitives::intersect_packet`]; an implementation may take the lanes as they are,
    /// with the same answers.
    #[inline]
    #[allow(clippy::needless_range_loop)] // lane loops index several arrays by the lane
    fn intersect_packet8(
        &self,
        prim: u32,
        rays: &LaneRays,
        active: [bool; LANES],
        origin: &LaneOrigins,
    ) -> [Option<PrimHit>; LANES] {
        let mut p = NO_RAYS;
        p.n = LANES;
        for i in 0..LANES {
            p.active[i] = active[i];
            for k in 0..3 {
                (p.org[k][i], p.dir[k][i]) = (rays.org[k][i], rays.dir[k][i]);
            }
            (p.tnear[i], p.tfar[i]) = (rays.tmin[i], rays.tmax[i]);
            if active[i] {
                p.origin[i] = origin.get(i);
            }
        }
        let mut hits = [None; MAX_PACKET];
        self.intersect_packet(prim, &p, &mut hits);
        std::array::from_fn(|i| hits[i].filter(|_| active[i]))
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

/// Where the lanes of a packet of [`LANES`] start on this geometry, as
/// [`UserPrimitives::intersect_packet8`] takes them: looked up lane by lane when asked, so that a
/// test that needs no lane's origin (most: a patch's hull turns every lane away) pays for none.
pub struct LaneOrigins {
    lookup: Lookup,
}

/// How [`LaneOrigins`] finds a lane's origin.
enum Lookup {
    /// Given by the caller, lane by lane.
    Given([Option<OriginPrim>; LANES]),
    /// Each lane's ray names its entry of a callback's registered origins by its `id`.
    Registered { origins: Origins, ids: [u32; LANES] },
}

impl LaneOrigins {
    /// No lane starts on this geometry.
    pub const NONE: LaneOrigins = LaneOrigins { lookup: Lookup::Given([None; LANES]) };

    /// Lane `i` starts at `origin[i]`.
    pub fn given(origin: [Option<OriginPrim>; LANES]) -> Self {
        LaneOrigins { lookup: Lookup::Given(origin) }
    }

    /// Where lane `i`'s ray starts on this geometry, if known.
    ///
    /// # Panics
    /// If `i >= LANES`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> Option<OriginPrim> {
        match &self.lookup {
            Lookup::Given(o) => o[i],
            Lookup::Registered { origins, ids } => origins.get(ids[i]),
        }
    }
}

impl std::fmt::Debug for LaneOrigins {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries((0..LANES).map(|i| self.get(i))).finish()
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

    #[inline(always)]
    fn intersect(&self, prim: u32, org: Vec3, dir: Vec3, tnear: f32, tfar: f32) -> Option<PrimHit> {
        (**self).intersect(prim, org, dir, tnear, tfar)
    }

    #[inline(always)]
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

    #[inline(always)]
    fn intersect_packet(&self, prim: u32, rays: &PacketRays, hits: &mut [Option<PrimHit>; MAX_PACKET]) {
        (**self).intersect_packet(prim, rays, hits)
    }

    #[inline(always)]
    fn intersect_packet8(
        &self,
        prim: u32,
        rays: &LaneRays,
        active: [bool; LANES],
        origin: &LaneOrigins,
    ) -> [Option<PrimHit>; LANES] {
        (**self).intersect_packet8(prim, rays, active, origin)
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
#[inline(always)]
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
#[inline(always)]
unsafe fn write_hit(hit: Soa, lane: usize, h: &PrimHit, geom: u32, context: *const sys::RTCRayQueryContext) {
    // SAFETY: every field written is one of the HIT_FIELDS of an RTCHitN of width n, lane < n,
    // and `context` is a valid query context (this function's contract).
    unsafe {
        hit.set_f(HIT_NG, lane, h.ng.x);
        hit.set_f(HIT_NG + 1, lane, h.ng.y);
        hit.set_f(HIT_NG + 2, lane, h.ng.z);
        hit.set_f(HIT_U, lane, h.u);
        hit.set_f(HIT_V, lane, h.v);
        hit.set_u(HIT_PRIM, lane, h.prim);
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
#[inline(always)]
fn lane_mask(n: usize, lane: usize) -> [i32; MAX_N] {
    let mut m = [0i32; MAX_N];
    if lane < n {
        m[lane] = -1;
    }
    m
}

// ---------------------------------------------------------------------------------------------
// Candidates and the filters.
//
// Embree 4 runs no filter on a user geometry's hits by itself: "the intersection filter function
// needs to be invoked by the user geometry intersection callback for each encountered
// intersection" (rtcSetGeometryIntersectFunction docs; likewise for occlusion), through
// rtcInvoke{Intersect,Occluded}FilterFromGeometry, which invokes "the intersection filter
// registered to the geometry" and nothing else. Whether one is registered cannot be asked
// through Embree's API (the caller's own code may set one on the geometry handle at any time):
// the invoke call is where Embree tests it (kernels/common/rtcore.cpp, 4.4:
// `if (args->geometry->intersectionFilterN) ...`), so every candidate goes through that call,
// a call and one test when no filter is set. The filter of the query's arguments
// (RTCIntersectArguments::filter, enabled by RTC_RAY_QUERY_FLAG_INVOKE_ARGUMENT_FILTER or
// rtcSetGeometryEnableFilterFunctionFromArguments) never runs for a user geometry: Embree 4 does
// not pass the arguments to the callback, and its release notes leave invoking it "manually" to
// an application that knows it; this geometry does not.
//
// What is left out is the rest of the route around the call: the candidate is written to a hit
// packet of our own, as the tutorial's `potentialHit` (user_geometry_device.cpp), not to the
// ray's hit, which is "undefined and should not be read" on entry (rtcSetGeometryIntersectFunction
// docs): it is never read, and written once, when the candidate is accepted. A rejection restores
// only the `tfar` the filter saw.

/// A hit packet of our own, `n` lanes wide, that the filters see a candidate in; zeroed when the
/// first candidate needs it (most calls find none). The filters are given its address, so it
/// lives apart from the offers that use it (by `&mut`): what they hold stays out of memory a
/// filter could reach, so the compiler keeps it in registers across the filter call, the
/// packet's width folded into the offsets of the hit fields (a packet's hit lane took about 30
/// instructions more with the buffer inside the offer).
struct Candidates {
    buf: MaybeUninit<HitBuf>,
    n: usize,
    ready: bool,
}

/// A stack RTCHitN of up to 16 lanes with the alignment Embree's packet types use.
#[repr(C, align(64))]
struct HitBuf([u32; HIT_FIELDS * MAX_N]);

impl Candidates {
    #[inline(always)]
    fn new(n: usize) -> Self {
        Candidates { buf: MaybeUninit::uninit(), n: n.min(MAX_N), ready: false }
    }

    /// The buffer as an RTCHitN of width `n`, every field of its `n` lanes initialised.
    #[inline(always)]
    fn soa(&mut self) -> Soa {
        let base = self.buf.as_mut_ptr() as *mut u32;
        if !self.ready {
            // SAFETY: the buffer holds HIT_FIELDS * MAX_N values and n <= MAX_N.
            unsafe { base.write_bytes(0, HIT_FIELDS * self.n) };
            self.ready = true;
        }
        Soa { base, n: self.n }
    }
}

/// Where the candidate hits of a callback go: offered to the filters, and kept when accepted.
trait Offer {
    /// Offer lane `lane`'s candidate `h` on the ray `r`: whether the filters accepted it.
    ///
    /// # Safety
    /// `lane` is below the width of the packet the offer was made for.
    unsafe fn offer(&mut self, lane: usize, r: &LaneRay, h: &PrimHit) -> bool;
}

/// The candidates of an intersect callback: an accepted one becomes the ray's hit.
struct IntersectOffer<'a> {
    args: *const sys::RTCIntersectFunctionNArguments,
    ray: Soa,
    hit: Soa,
    cand: &'a mut Candidates,
}

impl Offer for IntersectOffer<'_> {
    #[inline(always)]
    unsafe fn offer(&mut self, lane: usize, r: &LaneRay, h: &PrimHit) -> bool {
        // SAFETY: `args` is the intersect callback's argument block, `ray` and `hit` the two
        // parts of its RTCRayHitN of width n, `cand` our own RTCHitN of width n, lane < n
        // (contract). The filter sees the candidate with the ray's tfar set to it.
        unsafe {
            let a = &*self.args;
            let cand = self.cand.soa();
            write_hit(cand, lane, h, a.geomID, a.context);
            self.ray.set_f(RAY_TFAR, lane, h.t);
            let mut mask = lane_mask(self.ray.n, lane);
            let fargs = sys::RTCFilterFunctionNArguments {
                valid: mask.as_mut_ptr(),
                geometryUserPtr: a.geometryUserPtr,
                context: a.context,
                ray: a.rayhit as *mut sys::RTCRayN,
                hit: cand.base as *mut sys::RTCHitN,
                N: a.N,
            };
            // `fargs` describes the ray packet with one lane active and the candidate in our
            // hit packet; the geometry's filter may clear the lane or change the candidate
            // (rtcInvokeIntersectFilterFromGeometry docs: "only rays that are still valid
            // ... should update a hit").
            sys::rtcInvokeIntersectFilterFromGeometry(self.args, &fargs);
            if mask[lane] != -1 {
                self.ray.set_f(RAY_TFAR, lane, r.tfar);
                return false;
            }
            for k in 0..HIT_FIELDS {
                self.hit.set_u(k, lane, cand.u(k, lane));
            }
            true
        }
    }
}

/// The candidates of an occluded callback: an accepted one occludes the ray.
struct OccludedOffer<'a> {
    args: *const sys::RTCOccludedFunctionNArguments,
    ray: Soa,
    cand: &'a mut Candidates,
    /// Where an accepted hit is recorded for the lane's origin entry (see [`Blockers`]).
    blockers: Blockers,
}

impl Offer for OccludedOffer<'_> {
    #[inline(always)]
    unsafe fn offer(&mut self, lane: usize, r: &LaneRay, h: &PrimHit) -> bool {
        // SAFETY: as in `IntersectOffer::offer`, with `ray` the callback's RTCRayN; `blockers`
        // was made for the query this callback runs under (`Blockers::of`).
        unsafe {
            let a = &*self.args;
            let cand = self.cand.soa();
            write_hit(cand, lane, h, a.geomID, a.context);
            self.ray.set_f(RAY_TFAR, lane, h.t);
            let mut mask = lane_mask(self.ray.n, lane);
            let fargs = sys::RTCFilterFunctionNArguments {
                valid: mask.as_mut_ptr(),
                geometryUserPtr: a.geometryUserPtr,
                context: a.context,
                ray: a.ray,
                hit: cand.base as *mut sys::RTCHitN,
                N: a.N,
            };
            // As in `IntersectOffer::offer` (rtcInvokeOccludedFilterFromGeometry docs).
            sys::rtcInvokeOccludedFilterFromGeometry(self.args, &fargs);
            if mask[lane] != -1 {
                self.ray.set_f(RAY_TFAR, lane, r.tfar);
                return false;
            }
            // Occluded: Embree's convention is tfar = -inf.
            self.ray.set_f(RAY_TFAR, lane, f32::NEG_INFINITY);
            self.blockers.record(self.ray.u(RAY_ID, lane), a, h);
            true
        }
    }
}

// ---------------------------------------------------------------------------------------------
// One lane (rtcIntersect1 / rtcOccluded1, a renderer's rays one by one): an RTCRayN and an RTCHitN
// of width 1 hold field k at index k, so the candidate is an `RTCHit` of our own, every field
// written (nothing to zero), and the filters see it with a valid mask of one int.

/// Lane 0's candidate `h` on geometry `geom` as a one-lane hit, with the instance stack of
/// `context`.
///
/// # Safety
/// `context` must be the query's valid context.
#[inline(always)]
unsafe fn one_lane_hit(h: &PrimHit, geom: u32, context: *const sys::RTCRayQueryContext) -> sys::RTCHit {
    // SAFETY: a valid context (this function's contract).
    let ctx = unsafe { &*context };
    sys::RTCHit {
        Ng_x: h.ng.x,
        Ng_y: h.ng.y,
        Ng_z: h.ng.z,
        u: h.u,
        v: h.v,
        primID: h.prim,
        geomID: geom,
        instID: ctx.instID,
        instPrimID: ctx.instPrimID,
    }
}

/// The candidates of a one-lane intersect callback: an accepted one becomes the ray's hit.
struct IntersectOne {
    args: *const sys::RTCIntersectFunctionNArguments,
}

impl Offer for IntersectOne {
    #[inline(always)]
    unsafe fn offer(&mut self, _lane: usize, r: &LaneRay, h: &PrimHit) -> bool {
        // SAFETY: `args` is a one-lane intersect callback's argument block: `rayhit` an
        // RTCRayHitN of width 1 (the ray's 12 fields, then its hit's HIT_FIELDS), `context` the
        // query's. The filter sees the candidate with the ray's tfar set to it.
        unsafe {
            let a = &*self.args;
            let ray = Soa { base: a.rayhit as *mut u32, n: 1 };
            let mut cand = one_lane_hit(h, a.geomID, a.context);
            ray.set_f(RAY_TFAR, 0, h.t);
            let mut valid = -1i32;
            let fargs = sys::RTCFilterFunctionNArguments {
                valid: &mut valid,
                geometryUserPtr: a.geometryUserPtr,
                context: a.context,
                ray: a.rayhit as *mut sys::RTCRayN,
                hit: (&mut cand as *mut sys::RTCHit).cast(),
                N: a.N,
            };
            // As in `IntersectOffer::offer`, the packet one lane wide.
            sys::rtcInvokeIntersectFilterFromGeometry(self.args, &fargs);
            if valid != -1 {
                ray.set_f(RAY_TFAR, 0, r.tfar);
                return false;
            }
            let hit = ray.base.add(RAY_FIELDS);
            hit.copy_from_nonoverlapping((&cand as *const sys::RTCHit).cast(), HIT_FIELDS);
            true
        }
    }
}

/// The candidates of a one-lane occluded callback: an accepted one occludes the ray.
struct OccludedOne {
    args: *const sys::RTCOccludedFunctionNArguments,
    /// Where an accepted hit is recorded for the ray's origin entry (see [`Blockers`]).
    blockers: Blockers,
}

impl Offer for OccludedOne {
    #[inline(always)]
    unsafe fn offer(&mut self, _lane: usize, r: &LaneRay, h: &PrimHit) -> bool {
        // SAFETY: as in `IntersectOne::offer`, with `ray` the callback's RTCRayN of width 1;
        // `blockers` as in `OccludedOffer::offer`.
        unsafe {
            let a = &*self.args;
            let ray = Soa { base: a.ray as *mut u32, n: 1 };
            let mut cand = one_lane_hit(h, a.geomID, a.context);
            ray.set_f(RAY_TFAR, 0, h.t);
            let mut valid = -1i32;
            let fargs = sys::RTCFilterFunctionNArguments {
                valid: &mut valid,
                geometryUserPtr: a.geometryUserPtr,
                context: a.context,
                ray: a.ray,
                hit: (&mut cand as *mut sys::RTCHit).cast(),
                N: a.N,
            };
            // As in `OccludedOffer::offer`, the packet one lane wide.
            sys::rtcInvokeOccludedFilterFromGeometry(self.args, &fargs);
            if valid != -1 {
                ray.set_f(RAY_TFAR, 0, r.tfar);
                return false;
            }
            ray.set_f(RAY_TFAR, 0, f32::NEG_INFINITY);
            self.blockers.record(ray.u(RAY_ID, 0), a, h);
            true
        }
    }
}

// An RTCHit is the hit of a one-lane RTCHitN: its HIT_FIELDS values first, in that order.
const _: () = {
    use std::mem::offset_of;
    assert!(offset_of!(sys::RTCHit, Ng_x) == 4 * HIT_NG && offset_of!(sys::RTCHit, u) == 4 * HIT_U);
    assert!(offset_of!(sys::RTCHit, v) == 4 * HIT_V && offset_of!(sys::RTCHit, primID) == 4 * HIT_PRIM);
    assert!(
        offset_of!(sys::RTCHit, geomID) == 4 * HIT_GEOM && offset_of!(sys::RTCHit, instID) == 4 * HIT_INST
    );
    assert!(offset_of!(sys::RTCHit, instPrimID) == 4 * HIT_INST_PRIM);
    assert!(std::mem::size_of::<sys::RTCHit>() >= 4 * HIT_FIELDS);
};

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

/// The body of both versions of [`intersect_packet_callback`] (with `intersect_lanes`) and of
/// [`occluded_packet_callback`] (`occluded_lanes`): a macro, so that the closures run under
/// `panic::wrap` are written inside each version, and so compiled for its target (a closure
/// takes the target features of the function it is written in). Each width under its own
/// `wrap`, 8 with the width a constant (the SOA indexing and the lane loops fold away).
///
/// Safety: `$a` is `*$args`, valid arguments from Embree, and `$data` its geometryUserPtr.
macro_rules! packet_body {
    ($lanes:ident, $what:literal, $args:expr, $a:expr, $data:expr) => {{
        let (args, a, data) = ($args, $a, $data);
        let prims = &data.prims;
        match a.N as usize {
            // SAFETY: `a` is the argument block Embree passed, with its own N.
            8 => panic::wrap(&data.panics, $what, || unsafe { $lanes::<T>(args, a, prims, 8) }),
            n @ 2..=MAX_N => {
                // SAFETY: as above.
                panic::wrap(&data.panics, $what, || unsafe { $lanes::<T>(args, a, prims, n) })
            }
            _ => None,
        };
    }};
}

/// The intersect callback, its packet route ([`intersect_packet_callback`]) compiled for
/// baseline x86-64, or with `V3` for AVX2 and FMA ([`intersect_packet_callback_v3`]: chosen by
/// [`PacketCode::detect`] when the geometry is made). One lane takes the baseline route in both.
unsafe extern "C" fn intersect_callback<T: UserPrimitives, const V3: bool>(
    args: *const sys::RTCIntersectFunctionNArguments,
) {
    // SAFETY: Embree passes valid arguments for N lanes: `valid` has N ints, `rayhit` is an
    // RTCRayHitN of width N, `context` is the query's context, and geometryUserPtr is our
    // `UserData<T>` (rtcSetGeometryIntersectFunction docs), alive while the scene is.
    let a = unsafe { &*args };
    // SAFETY: as above.
    let data = unsafe { &*(a.geometryUserPtr as *const UserData<T>) };
    // One lane (rtcIntersect1, what a renderer calls per ray) is the body of this callback, with
    // a frame of its own size; packets go to a function of their own.
    if a.N == 1 {
        // SAFETY: `a` is the argument block Embree passed, with N = 1.
        panic::wrap(&data.panics, "intersect", || unsafe { intersect_one::<T>(args, a, &data.prims) });
    } else {
        #[cfg(target_arch = "x86_64")]
        if V3 {
            // SAFETY: as above, with N != 1, and with `V3` the geometry was made by
            // `PacketCode::detect` on a CPU with AVX2 and FMA (or by a test that checked them).
            return unsafe { intersect_packet_callback_v3::<T>(args, a, data) };
        }
        // SAFETY: as above, with N != 1.
        unsafe { intersect_packet_callback::<T>(args, a, data) }
    }
}

/// The body of [`intersect_callback`] for one lane.
///
/// # Safety
/// `a` is `*args`, valid arguments from Embree with `a.N == 1`, and `data` the primitives its
/// geometryUserPtr holds.
#[inline(always)]
unsafe fn intersect_one<T: UserPrimitives>(
    args: *const sys::RTCIntersectFunctionNArguments,
    a: &sys::RTCIntersectFunctionNArguments,
    data: &T,
) {
    // SAFETY: `valid` points to N = 1 int (RTCIntersectFunctionNArguments contract).
    if unsafe { a.valid.read() } != -1 {
        return;
    }
    let ray = Soa { base: a.rayhit as *mut u32, n: 1 };
    // SAFETY: lane 0 of the ray part of an RTCRayHitN of width 1.
    let r = unsafe { read_ray(ray, 0) };
    if let Some(first) = data.intersect_from(a.primID, None, r.org, r.dir, r.tnear, r.tfar) {
        // SAFETY: lane 0 < 1, and the offer is made for the packet Embree passed.
        unsafe { offer_hits(data, a.primID, 0, None, ray, first, &mut IntersectOne { args }) }
    }
}

/// [`intersect_callback`] for packets of N = 2..=16 lanes (8 with the width a constant, so
/// the SOA indexing and the lane loops fold away); each under its own `wrap`.
///
/// # Safety
/// `a` is `*args`, valid arguments from Embree, and `data` its geometryUserPtr.
#[inline(never)]
unsafe fn intersect_packet_callback<T: UserPrimitives>(
    args: *const sys::RTCIntersectFunctionNArguments,
    a: &sys::RTCIntersectFunctionNArguments,
    data: &UserData<T>,
) {
    // Safety: this function's contract is the macro's.
    packet_body!(intersect_lanes, "intersect", args, a, data)
}

/// [`intersect_packet_callback`] compiled for AVX2 and FMA: the lanes read, masked and offered
/// in 256-bit registers. The same operations as the baseline version (Rust contracts no
/// `a * b + c` into a fused one), so the same answers (`tests/packets.rs`, and this module's
/// tests against the baseline version).
///
/// # Safety
/// As [`intersect_packet_callback`], and the CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[inline(never)]
#[target_feature(enable = "avx2,fma")]
unsafe fn intersect_packet_callback_v3<T: UserPrimitives>(
    args: *const sys::RTCIntersectFunctionNArguments,
    a: &sys::RTCIntersectFunctionNArguments,
    data: &UserData<T>,
) {
    // Safety: this function's contract is the macro's.
    packet_body!(intersect_lanes, "intersect", args, a, data)
}

/// Offer each active lane's candidate hits on `prim` in a packet, nearest first, to `offer`,
/// which says whether the filters accepted each. A primitive can be crossed several times:
/// after a rejected candidate, look beyond it (at most [`MAX_CANDIDATES`]: 4 roots for each of a
/// cluster's 8 patches, the resultant of a line and a quadratic patch being a quartic). A
/// rejection restores the lane's `tfar`, so its value read here holds. `origin(lane)` is where
/// the lane's ray starts on this geometry, if known (occlusion rays of [`CommittedScene::occluded8_rays_from`]).
/// The first candidates come from [`UserPrimitives::intersect_packet`], all the lanes (and their
/// origins) at once; one lane has a route of its own ([`intersect_one`], [`occluded_one`]).
///
/// # Safety
/// `ray` must be an RTCRayN (or the ray part of an RTCRayHitN) of width `valid.len()`, and
/// `offer` made for that packet.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane loops index several arrays by the lane
unsafe fn for_each_candidate<T: UserPrimitives>(
    data: &T,
    prim: u32,
    valid: &[i32],
    ray: Soa,
    origins: Origins,
    offer: &mut impl Offer,
) {
    if let Ok(valid) = <&[i32; LANES]>::try_from(valid) {
        // SAFETY: as this function's.
        return unsafe { for_each_candidate8(data, prim, valid, ray, origins, offer) };
    }
    let mut rays = NO_RAYS;
    // SAFETY: `read_packet` asks only for lanes below valid.len(), the width of the RTCRayN
    // `ray` (this function's contract).
    let origin = |lane: usize| origins.get(unsafe { ray.u(RAY_ID, lane) });
    // SAFETY: the layout is RTCRayN of width valid.len() (this function's contract).
    unsafe { read_packet(ray, valid, origin, &mut rays) };
    let mut hits = [None; MAX_N];
    data.intersect_packet(prim, &rays, &mut hits);
    for lane in 0..rays.n {
        let (true, Some(first)) = (rays.active[lane], hits[lane]) else { continue };
        // SAFETY: lane < n (contract).
        unsafe { offer_lane_hits(data, prim, lane, rays.origin[lane], ray, first, offer) };
    }
}

/// [`for_each_candidate`] for a packet of [`LANES`]: the lanes read straight into the
/// [`LaneRays`] that [`UserPrimitives::intersect_packet8`] takes (no packet of 16 lanes to
/// zero and copy from).
///
/// # Safety
/// As [`for_each_candidate`], with `ray` of width [`LANES`].
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane loops index several arrays by the lane
unsafe fn for_each_candidate8<T: UserPrimitives>(
    data: &T,
    prim: u32,
    valid: &[i32; LANES],
    ray: Soa,
    origins: Origins,
    offer: &mut impl Offer,
) {
    let mut active = [false; LANES];
    for lane in 0..LANES {
        active[lane] = valid[lane] == -1;
    }
    // Compute the lanes' rays field by field, the inactive lanes zero (as `read_packet`).
    let field = |k: usize| {
        let mut out = [0.0f32; LANES];
        for lane in 0..LANES {
            // SAFETY: lane < LANES, the width of the RTCRayN `ray` (contract).
            let x = unsafe { ray.f(k, lane) };
            out[lane] = if active[lane] { x } else { 0.0 };
        }
        out
    };
    let rays = LaneRays {
        org: [field(RAY_ORG), field(RAY_ORG + 1), field(RAY_ORG + 2)],
        dir: [field(RAY_DIR), field(RAY_DIR + 1), field(RAY_DIR + 2)],
        tmin: field(RAY_TNEAR),
        tmax: field(RAY_TFAR),
    };
    // The lanes' entries of the origins, looked up when asked (inactive lanes and rays that
    // name none: 0).
    let mut ids = [0u32; LANES];
    if origins.len != 0 {
        for lane in 0..LANES {
            // SAFETY: lane < LANES, the width of the RTCRayN `ray` (contract).
            let id = unsafe { ray.u(RAY_ID, lane) };
            ids[lane] = if active[lane] { id } else { 0 };
        }
    }
    let origins = LaneOrigins { lookup: Lookup::Registered { origins, ids } };
    let hits = data.intersect_packet8(prim, &rays, active, &origins);
    // Most calls find no hit: one test of the eight answers, without a branch per lane.
    if !hits.iter().fold(false, |any, h| any | h.is_some()) {
        return;
    }
    for lane in 0..LANES {
        let (true, Some(first)) = (active[lane], hits[lane]) else { continue };
        // SAFETY: lane < LANES (contract).
        unsafe { offer_lane_hits(data, prim, lane, origins.get(lane), ray, first, offer) };
    }
}

/// Offer `first`, lane `lane`'s nearest hit on `prim`, then (while the filters reject) the
/// next ones beyond it, as [`for_each_candidate`] describes. A function of its own, entered only
/// by a lane with a hit (most calls find none), which reads the lane's ray again from `ray`
/// (unchanged since the first test), so that the caller need not keep it across that test.
///
/// # Safety
/// `ray` must be an RTCRayN (or the ray part of an RTCRayHitN) with `lane` below its width,
/// and `offer` made for that packet.
#[inline(never)]
unsafe fn offer_hits<T: UserPrimitives>(
    data: &T,
    prim: u32,
    lane: usize,
    from: Option<OriginPrim>,
    ray: Soa,
    first: PrimHit,
    offer: &mut impl Offer,
) {
    // SAFETY: this function's contract is `offer_lane_hits`'.
    unsafe { offer_lane_hits(data, prim, lane, from, ray, first, offer) }
}

/// The body of [`offer_hits`], inlined into the packet callbacks' lane loop (where a call per
/// lane with a hit cost 8-ray primary packets about 13 instructions per ray).
///
/// # Safety
/// As [`offer_hits`].
#[inline(always)]
unsafe fn offer_lane_hits<T: UserPrimitives>(
    data: &T,
    prim: u32,
    lane: usize,
    from: Option<OriginPrim>,
    ray: Soa,
    first: PrimHit,
    offer: &mut impl Offer,
) {
    // SAFETY: lane is below the width of `ray` (this function's contract).
    let r = &unsafe { read_ray(ray, lane) };
    let (mut next, mut tnear) = (Some(first), r.tnear);
    for _ in 0..MAX_CANDIDATES {
        let Some(h) = next else { break };
        // Embree takes the hit's t as the ray's new tfar: one outside the interval asked for
        // (or NaN) would be a hit behind the origin or past a nearer one. Refused, and counted
        // ([`user_hits_out_of_range`]).
        if !(h.t > tnear && h.t < r.tfar) {
            OUT_OF_RANGE.fetch_add(1, Ordering::Relaxed);
            break;
        }
        // SAFETY: lane is within the offer's packet (contract).
        if unsafe { offer.offer(lane, r, &h) } {
            break;
        }
        tnear = h.t;
        next = data.intersect_from(prim, from, r.org, r.dir, h.t, r.tfar);
    }
}

/// The rays of a packet of width `valid.len()` (at most [`MAX_N`]), the lanes `valid` marks
/// active (Embree's `-1`) with their origins `origin(lane)`, the other lanes' fields zero,
/// written to `p` (zeroed by the caller).
///
/// # Safety
/// `ray` must be an RTCRayN of width `valid.len()`.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane loops index several arrays by the lane
unsafe fn read_packet(
    ray: Soa,
    valid: &[i32],
    origin: impl Fn(usize) -> Option<OriginPrim>,
    p: &mut PacketRays,
) {
    let n = valid.len().min(MAX_N);
    p.n = n;
    for lane in 0..n {
        p.active[lane] = valid[lane] == -1;
    }
    // Field by field, every lane read and the inactive ones zeroed: loops over the lanes that
    // the compiler vectorises (Embree's own packet traversal loads every lane of these fields).
    for (k, field) in
        [RAY_ORG, RAY_ORG + 1, RAY_ORG + 2, RAY_DIR, RAY_DIR + 1, RAY_DIR + 2, RAY_TNEAR, RAY_TFAR]
            .into_iter()
            .enumerate()
    {
        let out = match k {
            0..=2 => &mut p.org[k],
            3..=5 => &mut p.dir[k - 3],
            6 => &mut p.tnear,
            _ => &mut p.tfar,
        };
        for lane in 0..n {
            // SAFETY: lane < n and the layout is RTCRayN of width n (this function's contract).
            let x = unsafe { ray.f(field, lane) };
            out[lane] = if p.active[lane] { x } else { 0.0 };
        }
    }
    for lane in 0..n {
        if p.active[lane] {
            p.origin[lane] = origin(lane);
        }
    }
}

/// A packet of no rays, for [`read_packet`] to fill.
const NO_RAYS: PacketRays = PacketRays {
    n: 0,
    active: [false; MAX_N],
    org: [[0.0; MAX_N]; 3],
    dir: [[0.0; MAX_N]; 3],
    tnear: [0.0; MAX_N],
    tfar: [0.0; MAX_N],
    origin: [None; MAX_N],
};

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
    let mut cand = Candidates::new(n);
    let mut offer = IntersectOffer { args, ray, hit, cand: &mut cand };
    // SAFETY: `ray` is the ray part of the packet Embree passed, of width n, and the offer is
    // made for it.
    unsafe { for_each_candidate(data, a.primID, valid, ray, Origins::NONE, &mut offer) }
}

/// The occluded callback, its packet route chosen as [`intersect_callback`]'s.
unsafe extern "C" fn occluded_callback<T: UserPrimitives, const V3: bool>(
    args: *const sys::RTCOccludedFunctionNArguments,
) {
    // SAFETY: as in `intersect_callback`, with `ray` an RTCRayN of width N
    // (rtcSetGeometryOccludedFunction docs).
    let a = unsafe { &*args };
    // SAFETY: as above.
    let data = unsafe { &*(a.geometryUserPtr as *const UserData<T>) };
    // One lane here, packets apart, as in `intersect_callback`.
    if a.N == 1 {
        // SAFETY: `a` is the argument block Embree passed, with N = 1.
        panic::wrap(&data.panics, "occluded", || unsafe { occluded_one::<T>(args, a, &data.prims) });
    } else {
        #[cfg(target_arch = "x86_64")]
        if V3 {
            // SAFETY: as above, with N != 1; `V3` as in `intersect_callback`.
            return unsafe { occluded_packet_callback_v3::<T>(args, a, data) };
        }
        // SAFETY: as above, with N != 1.
        unsafe { occluded_packet_callback::<T>(args, a, data) }
    }
}

/// The body of [`occluded_callback`] for one lane.
///
/// # Safety
/// `a` is `*args`, valid arguments from Embree with `a.N == 1`, and `data` the primitives its
/// geometryUserPtr holds.
#[inline(always)]
unsafe fn occluded_one<T: UserPrimitives>(
    args: *const sys::RTCOccludedFunctionNArguments,
    a: &sys::RTCOccludedFunctionNArguments,
    data: &T,
) {
    // SAFETY: `valid` points to N = 1 int (RTCOccludedFunctionNArguments contract).
    if unsafe { a.valid.read() } != -1 {
        return;
    }
    let ray = Soa { base: a.ray as *mut u32, n: 1 };
    // Compute the origin first (only a ray that names an entry looks for the registration),
    // then read the ray: nothing of it is held across the lookup.
    // SAFETY: lane 0 of an RTCRayN of width 1.
    let id = unsafe { ray.u(RAY_ID, 0) };
    let head = if id == 0 { None } else { registered(a.context) };
    // SAFETY: `head` is registered for the running query, `a.context` Embree's pointer to its
    // context.
    let from = unsafe { Origins::of(head, a.context, a.geomID) }.get(id);
    // SAFETY: lane 0 of an RTCRayN of width 1.
    let r = unsafe { read_ray(ray, 0) };
    if let Some(first) = data.intersect_from(a.primID, from, r.org, r.dir, r.tnear, r.tfar) {
        let blockers = Blockers::of(head);
        // SAFETY: lane 0 < 1, and the offer is made for the packet Embree passed, its blockers
        // for the query it runs under.
        unsafe { offer_hits(data, a.primID, 0, from, ray, first, &mut OccludedOne { args, blockers }) }
    }
}

/// [`occluded_callback`] for packets, as [`intersect_packet_callback`].
///
/// # Safety
/// `a` is `*args`, valid arguments from Embree, and `data` its geometryUserPtr.
#[inline(never)]
unsafe fn occluded_packet_callback<T: UserPrimitives>(
    args: *const sys::RTCOccludedFunctionNArguments,
    a: &sys::RTCOccludedFunctionNArguments,
    data: &UserData<T>,
) {
    // Safety: this function's contract is the macro's.
    packet_body!(occluded_lanes, "occluded", args, a, data)
}

/// [`occluded_packet_callback`] compiled for AVX2 and FMA, as [`intersect_packet_callback_v3`].
///
/// # Safety
/// As [`occluded_packet_callback`], and the CPU has AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[inline(never)]
#[target_feature(enable = "avx2,fma")]
unsafe fn occluded_packet_callback_v3<T: UserPrimitives>(
    args: *const sys::RTCOccludedFunctionNArguments,
    a: &sys::RTCOccludedFunctionNArguments,
    data: &UserData<T>,
) {
    // Safety: this function's contract is the macro's.
    packet_body!(occluded_lanes, "occluded", args, a, data)
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
    // The registration and its origins once for the packet, each lane's entry by its id.
    let head = registered(a.context);
    // SAFETY: `head` is registered for the running query and `a.context` is Embree's pointer to
    // its context.
    let origins = unsafe { Origins::of(head, a.context, a.geomID) };
    let mut cand = Candidates::new(n);
    let mut offer = OccludedOffer { args, ray, cand: &mut cand, blockers: Blockers::of(head) };
    // SAFETY: `ray` is the ray part of the packet Embree passed, of width n, and the offer is
    // made for it.
    unsafe { for_each_candidate(data, a.primID, valid, ray, origins, &mut offer) }
}

// ---------------------------------------------------------------------------------------------
// Origin-aware occlusion: the query context extended with where each ray starts (Embree 4 passes
// the caller's `RTCRayQueryContext` pointer to the callbacks as is, so data may follow it: "the
// context can be extended", rtcInitRayQueryContext docs). A ray names its entry by its `id`
// (entry k + 1; 0: none), which Embree carries through traversal, instancing and packet splits
// unchanged. A callback reads past the raw context only when the context is the one this thread
// registered for the query it runs under, and only for a ray that names an entry.

/// What every [`OriginContext`] starts with: the context Embree sees (first, so a pointer to it
/// is a pointer to the whole), how many origins follow, and where the callbacks record what
/// occluded each ray (null: not asked).
#[repr(C)]
struct OriginHead {
    /// What Embree sees.
    base: QueryContext,
    /// The number of origins that follow the head.
    len: usize,
    /// `len` blockers, entry `k` for the ray with `id == k + 1`, or null (see [`Blockers`]).
    blockers: *mut Blocker,
}

/// A query context followed by the origins of the query's `N` rays.
#[repr(C)]
struct OriginContext<const N: usize> {
    head: OriginHead,
    /// Entry `k` for the rays with `id == k + 1`.
    origins: [RayOrigin; N],
}

// The origins start right after the head whatever N is (repr(C), and the head's size is a
// multiple of a RayOrigin's alignment): a callback finds them from the head alone.
const _: () = assert!(std::mem::offset_of!(OriginContext<1>, origins) == std::mem::size_of::<OriginHead>());
const _: () =
    assert!(std::mem::offset_of!(OriginContext<PACKET8>, origins) == std::mem::size_of::<OriginHead>());

/// Where a callback records what occluded a ray ([`Blocker`]): the blockers the query's
/// registered [`OriginContext`] points to, entry `k` for the ray with `id == k + 1`; nothing
/// where the query asked for none.
#[derive(Clone, Copy)]
struct Blockers {
    base: *mut Blocker,
    len: usize,
}

impl Blockers {
    /// The blockers of the registered context `head` (see [`registered`]), if it asks for them.
    #[inline(always)]
    fn of(head: Option<*const OriginHead>) -> Self {
        let Some(head) = head else { return Blockers { base: std::ptr::null_mut(), len: 0 } };
        // SAFETY: `head` is the registered context of the running query, alive until it returns
        // (`OriginContext::query`); its fields are read through the registered pointer (Embree
        // writes only the base). `blockers` is null or `len` entries the query's caller holds
        // exclusively until the query returns (`OriginContext::query`).
        unsafe {
            let base = std::ptr::addr_of!((*head).blockers).read();
            let len = if base.is_null() { 0 } else { std::ptr::addr_of!((*head).len).read() };
            Blockers { base, len }
        }
    }

    /// Record the accepted hit `h` of the callback `a` as what occluded the ray with `id`:
    /// outside instances only, and only for a ray that names an entry.
    ///
    /// # Safety
    /// `a` must be the running callback's valid arguments, under the query `self` was made for.
    #[inline(always)]
    unsafe fn record(&self, id: u32, a: &sys::RTCOccludedFunctionNArguments, h: &PrimHit) {
        let k = id.wrapping_sub(1) as usize;
        if k >= self.len {
            return;
        }
        // SAFETY: `a.context` is the query's context (callback contract); entry k < len is in
        // the registered context's blockers (`Blockers::of`), written by this thread alone.
        unsafe {
            if (*a.context).instID[0] != u32::MAX {
                return;
            }
            self.base.add(k).write(Blocker { geom_id: a.geomID, prim: h.prim, t: h.t });
        }
    }
}

thread_local! {
    /// The [`OriginContext`] of the origin-aware query running on this thread (null: none), as
    /// a pointer to its head with the provenance of the whole context.
    static ORIGIN_CONTEXT: Cell<*const OriginHead> = const { Cell::new(std::ptr::null()) };
}

/// Restores the thread's registered [`OriginContext`] when a query ends, by return or unwind.
struct Registered(*const OriginHead);

impl Drop for Registered {
    fn drop(&mut self) {
        ORIGIN_CONTEXT.with(|c| c.set(self.0));
    }
}

impl<const N: usize> OriginContext<N> {
    fn new(origins: [RayOrigin; N]) -> Self {
        OriginContext {
            head: OriginHead { base: QueryContext::new(), len: N, blockers: std::ptr::null_mut() },
            origins,
        }
    }

    /// [`OriginContext::query`], the callbacks recording in `blockers[k]` what occluded the ray
    /// with `id == k + 1` (entries they do not write are left as they are).
    #[inline(always)]
    fn query_by<R>(
        &mut self,
        coherent: bool,
        blockers: &mut [Blocker; N],
        f: impl FnOnce(&mut OccludedArgs<'_>) -> R,
    ) -> R {
        self.head.blockers = blockers.as_mut_ptr();
        let r = self.query(coherent, f);
        self.head.blockers = std::ptr::null_mut();
        r
    }

    /// Run the query `f(args)` with arguments whose context is `self`, registered as this
    /// thread's origin context while it runs.
    #[inline(always)]
    fn query<R>(&mut self, coherent: bool, f: impl FnOnce(&mut OccludedArgs<'_>) -> R) -> R {
        let p: *mut Self = self;
        // SAFETY: `p` points to `self`, borrowed exclusively for this call; the base is the one
        // part Embree writes through (its instance stack), and the callbacks read the rest (the
        // length and the origins) through `p`, registered below (`Origins::of`).
        let base = unsafe { &mut (*p).head.base };
        let mut args = OccludedArgs::new().flags(query_flags(coherent)).context(base);
        let _outer = Registered(ORIGIN_CONTEXT.with(|c| c.replace(p as *const OriginHead)));
        f(&mut args)
    }
}

/// The thread's registered [`OriginContext`], if `context` is it.
#[inline(always)]
fn registered(context: *const sys::RTCRayQueryContext) -> Option<*const OriginHead> {
    let head = ORIGIN_CONTEXT.with(Cell::get);
    (!head.is_null() && head as *const sys::RTCRayQueryContext == context).then_some(head)
}

/// The origins of the registered context a callback runs under, as it reads them: where the
/// entries are, how many, and what an entry must match to be an origin on this geometry (the
/// callback's geometry and the context's instance stack now), read once per callback. Made by
/// [`Origins::of`] in a callback and used only there, while its query runs: the entries stay
/// valid that long, which is what [`Origins::get`] relies on.
#[derive(Clone, Copy)]
struct Origins {
    entries: *const RayOrigin,
    len: usize,
    geom: u32,
    stack: [u32; MAX_INSTANCE_LEVEL_COUNT],
}

impl Origins {
    /// No origins: every ray's is `None`.
    const NONE: Origins = Origins {
        entries: std::ptr::null(),
        len: 0,
        geom: u32::MAX,
        stack: [u32::MAX; MAX_INSTANCE_LEVEL_COUNT],
    };

    /// The origins of the registered context `head` ([`registered`]), none without one, for a
    /// callback on geometry `geom`.
    ///
    /// # Safety
    /// `head` must be the registered context of the running query, and `context` Embree's
    /// pointer to it.
    #[inline(always)]
    unsafe fn of(
        head: Option<*const OriginHead>,
        context: *const sys::RTCRayQueryContext,
        geom: u32,
    ) -> Self {
        let Some(head) = head else { return Origins::NONE };
        // SAFETY: `head` is the registered context of the query this callback runs under, which
        // `OriginContext::query` keeps alive (on its caller's stack) until it returns; its length
        // is read through the registered pointer (Embree writes only the base), and the origins
        // start right after the head (asserted above). The instance stack is read through
        // Embree's own pointer to the base.
        unsafe {
            Origins {
                entries: head.add(1) as *const RayOrigin,
                len: std::ptr::addr_of!((*head).len).read(),
                geom,
                stack: (*context).instID,
            }
        }
    }

    /// The origin of the ray with `id` when it starts on this geometry at the instance level
    /// the query is at now: `None` for a ray that names no entry (`id == 0`, or past the
    /// origins).
    #[inline(always)]
    fn get(&self, id: u32) -> Option<OriginPrim> {
        // `id == 0` wraps past every length.
        let k = (id as usize).wrapping_sub(1);
        if k >= self.len {
            return None;
        }
        // SAFETY: entry k < len of the registered context's origins, alive for the running
        // query (`Origins::of`).
        let o = unsafe { self.entries.add(k).read() };
        (o.geom_id == self.geom && o.inst_id == self.stack).then_some(OriginPrim {
            prim: o.prim,
            u: o.u,
            v: o.v,
        })
    }
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
        let Some(o) = origin else { return self.occluded1(ray) };
        let mut ctx = OriginContext::<1>::new([o]);
        let mut r = ray.to_sys();
        r.id = 1;
        ctx.query(false, |args| self.occluded1_raw(&mut r, Some(args)));
        r.tfar == f32::NEG_INFINITY
    }

    /// [`CommittedScene::occluded1_from`], with what occluded the ray: `None` where nothing
    /// does, `Some(blocker)` where something does, with the accepted hit where it was on a user
    /// geometry of this crate outside instances and `origin` was given ([`Blocker`]).
    pub fn occluded1_by(&self, ray: Ray, origin: Option<RayOrigin>) -> Option<Option<Blocker>> {
        let Some(o) = origin else { return self.occluded1(ray).then_some(None) };
        let mut ctx = OriginContext::<1>::new([o]);
        let mut r = ray.to_sys();
        r.id = 1;
        let mut by = [NO_BLOCKER];
        ctx.query_by(false, &mut by, |args| self.occluded1_raw(&mut r, Some(args)));
        (r.tfar == f32::NEG_INFINITY).then_some((by[0].geom_id != u32::MAX).then_some(by[0]))
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
        self.occluded8_query(rays, origins, active, coherent, None)
    }

    /// [`CommittedScene::occluded8_rays_from`], with what occluded each lane, as
    /// [`CommittedScene::occluded1_by`] gives it: the mask of occluded lanes, and lane `k`'s
    /// [`Blocker`] where one was recorded.
    pub fn occluded8_rays_by(
        &self,
        rays: &[Ray; PACKET8],
        origins: &[Option<RayOrigin>; PACKET8],
        active: u8,
        coherent: bool,
    ) -> (u8, [Option<Blocker>; PACKET8]) {
        let mut by = [NO_BLOCKER; PACKET8];
        let blocked = self.occluded8_query(rays, origins, active, coherent, Some(&mut by));
        if blocked == 0 {
            return (0, [None; PACKET8]);
        }
        (
            blocked,
            std::array::from_fn(|k| (blocked & (1 << k) != 0 && by[k].geom_id != u32::MAX).then_some(by[k])),
        )
    }

    /// The query of [`CommittedScene::occluded8_rays_from`], recording the lanes' blockers in
    /// `by` where given.
    #[inline(always)]
    fn occluded8_query(
        &self,
        rays: &[Ray; PACKET8],
        origins: &[Option<RayOrigin>; PACKET8],
        active: u8,
        coherent: bool,
        by: Option<&mut [Blocker; PACKET8]>,
    ) -> u8 {
        if active == 0 {
            return 0;
        }
        let mut ctx = OriginContext::<PACKET8>::new([NO_ORIGIN; PACKET8]);
        let mut ray = rayhit8(rays).ray;
        for (k, o) in origins.iter().enumerate() {
            if let Some(o) = o {
                ctx.origins[k] = *o;
                ray.id[k] = k as u32 + 1;
            }
        }
        let query = |args: &mut OccludedArgs<'_>| self.occluded8(&valid8(active), &mut ray, Some(args));
        match by {
            Some(by) => ctx.query_by(coherent, by, query),
            None => ctx.query(coherent, query),
        };
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
    // SAFETY: this function's contract; the packet code is this CPU's.
    unsafe { new_user_geometry_for(device_raw, data, options, PacketCode::detect()) }
}

/// The code the packet callbacks run: compiled for baseline x86-64 (or the target's own), or
/// for AVX2 and FMA where the CPU has them (x86-64 only). Chosen once, when a geometry is made:
/// the callbacks Embree is given are those of the choice, with no test per call.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PacketCode {
    /// The crate's own target.
    Baseline,
    /// AVX2 and FMA (x86-64 only).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    Avx2Fma,
}

impl PacketCode {
    /// The fastest this CPU runs.
    pub(crate) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            return PacketCode::Avx2Fma;
        }
        PacketCode::Baseline
    }
}

/// [`new_user_geometry`] with the packet callbacks of `code`.
///
/// # Safety
/// As [`new_user_geometry`], and the CPU runs `code` (as [`PacketCode::detect`] says).
pub(crate) unsafe fn new_user_geometry_for<T: UserPrimitives>(
    device_raw: sys::RTCDevice,
    data: *const UserData<T>,
    options: GeometryOptions,
    code: PacketCode,
) -> sys::RTCGeometry {
    let (intersect, occluded): (sys::RTCIntersectFunctionN, sys::RTCOccludedFunctionN) = match code {
        PacketCode::Baseline => (Some(intersect_callback::<T, false>), Some(occluded_callback::<T, false>)),
        PacketCode::Avx2Fma => (Some(intersect_callback::<T, true>), Some(occluded_callback::<T, true>)),
    };
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
        sys::rtcSetGeometryIntersectFunction(geom, intersect);
        sys::rtcSetGeometryOccludedFunction(geom, occluded);
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
        // SAFETY: `detect` names the code this CPU runs.
        unsafe { self.attach_user_for(prims, options, PacketCode::detect()) }
    }

    /// [`Scene::attach_user`] with the packet callbacks of `code`.
    ///
    /// # Safety
    /// This CPU runs `code` (as [`PacketCode::detect`] says): the AVX2 callbacks on a CPU
    /// without AVX2 and FMA would execute instructions it does not have.
    unsafe fn attach_user_for<T: UserPrimitives>(
        &mut self,
        prims: T,
        options: GeometryOptions,
        code: PacketCode,
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
                // field order); the CPU runs `code` (this function's contract).
                unsafe { new_user_geometry_for(device.raw(), ptr, options, code) }
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

    // Lane by lane from the lanes as the callback read them: the default would copy them into a
    // packet of 16 first, which a floor should not pay.
    #[inline(always)]
    fn intersect_packet8(
        &self,
        prim: u32,
        rays: &LaneRays,
        active: [bool; LANES],
        _origin: &LaneOrigins,
    ) -> [Option<PrimHit>; LANES] {
        std::array::from_fn(|i| {
            let (org, dir) = active[i].then(|| rays.ray(i))?;
            self.intersect(prim, org.into(), dir.into(), rays.tmin[i], rays.tmax[i])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::embree::{Device, PhongMesh};
    use crate::phong::accuracy::SplitMix;

    /// The packet callbacks compiled for AVX2 and FMA answer as the baseline ones, bit for bit:
    /// 8-ray packets of camera rays and of random rays on a Phong sphere, every mask, then
    /// their shadow rays from the hits (the origins given), both versions' hits and occlusions
    /// compared lane by lane.
    #[test]
    fn the_avx2_packet_callbacks_answer_as_the_baseline_ones() {
        if PacketCode::detect() != PacketCode::Avx2Fma {
            eprintln!("this CPU lacks AVX2 or FMA: only the baseline callbacks run here");
            return;
        }
        let device = Device::new().unwrap();
        let m = crate::scene::uv_sphere(12, 6, 1.0);
        let mesh = Arc::new(PhongMesh::new(&m.positions, &m.normals, &m.indices, 0.75).unwrap());
        let scene = |code| {
            let mut s = Scene::new(&device).unwrap();
            // SAFETY: this CPU has AVX2 and FMA (checked above), and runs the baseline code.
            unsafe { s.attach_user_for(mesh.clone(), GeometryOptions::default(), code) }.unwrap();
            s.commit().unwrap()
        };
        let (base, v3) = (scene(PacketCode::Baseline), scene(PacketCode::Avx2Fma));
        let mut rng = SplitMix(23);
        let light = Vec3::new(-0.4, 0.8, 0.45).normalize();
        let (mut hits, mut blocked) = (0, 0);
        for i in 0..4000 {
            let rays: [Ray; PACKET8] = std::array::from_fn(|k| {
                if i % 2 == 0 {
                    // A 4x2 block of camera rays.
                    let (x, y) = ((i / 2 % 40) * 4 + k % 4, (i / 80) * 2 + k / 4);
                    let s = Vec3::new(x as f32 / 160.0 - 0.5, 0.5 - y as f32 / 100.0, -1.0);
                    Ray::new(Vec3::new(0.1, 0.2, 3.0), s * Vec3::new(2.6, 2.6, 1.0))
                } else {
                    let o = rng.unit().as_vec3() * 3.0;
                    Ray::new(o, rng.unit().as_vec3() * 0.9 - o)
                }
            });
            let mask = if i % 3 == 0 { 0xFF } else { rng.next_u64() as u8 };
            let (a, b) = (base.intersect8_rays(&rays, mask, true), v3.intersect8_rays(&rays, mask, true));
            // Bit for bit: the hits' Debug text tells -0.0 from 0.0, as `==` does not.
            assert_eq!(format!("{a:?}"), format!("{b:?}"), "packet {i}, mask {mask:#04x}");
            let mut shadow = [Ray::new(Vec3::ZERO, light); PACKET8];
            let mut origins = [None; PACKET8];
            let mut lit = 0u8;
            for (k, h) in a.iter().enumerate() {
                let Some(h) = h else { continue };
                let n = if h.ng.dot(rays[k].dir) > 0.0 { -h.ng } else { h.ng };
                let p = rays[k].org + rays[k].dir * h.t + n.normalize() * 1e-4;
                (shadow[k], origins[k]) = (Ray::new(p, light), Some(RayOrigin::of_hit(h)));
                lit |= 1 << k;
                hits += 1;
            }
            let occ = base.occluded8_rays_from(&shadow, &origins, lit, true);
            assert_eq!(occ, v3.occluded8_rays_from(&shadow, &origins, lit, true), "shadows of packet {i}");
            blocked += occ.count_ones();
        }
        assert!(hits > 5_000 && blocked > 500, "{hits} hits, {blocked} shadow rays blocked");
    }
}
