//! The server's publishing ports: the `frame` and `objects` publishers with their lossless
//! bookkeeping, and publishing a scene or a frame straight from the simulation into loaned
//! shared memory.

use iceoryx2::node::Node;
use iceoryx2::port::backpressure_strategy::BackpressureStrategy;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::AllocationStrategy;

use crate::backpressure::LagBook;
use crate::error::IpcError;
use crate::services::{
    FrameService, Iox, ObjectsService, ServiceNames, frame_subscribers, objects_subscribers,
};
use crate::simulation::Simulation;
use crate::wire::{
    FrameGaussian, FrameHeader, LAYOUT_VERSION, MAX_NAMED_OBJECTS, ObjectName, ObjectState,
    SceneGaussian, SceneHeader, write_fixed_str,
};

/// A service's subscribers as the books see them: (iceoryx2 subscriber id, lossless).
pub(super) type Subscribers = Vec<(u128, bool)>;

pub(super) struct Ports {
    pub(super) names: ServiceNames,
    pub(super) frame_service: FrameService,
    pub(super) objects_service: ObjectsService,
    pub(super) frame_pub: Publisher<Iox, [FrameGaussian], FrameHeader>,
    pub(super) objects_pub: Publisher<Iox, [ObjectState], FrameHeader>,
    pub(super) frame_book: LagBook,
    pub(super) objects_book: LagBook,
    /// The `frame` and `objects` subscribers the books were last given: (id, lossless).
    pub(super) subscribers: (Subscribers, Subscribers),
}

impl Ports {
    /// Re-reads which subscribers exist and which ask for lossless delivery, and tells the
    /// books when that changed. The lists are compared, not their lengths: a dead recorder
    /// cleaned up while a new one attaches leaves the count as it was, and the new recorder,
    /// unknown to the book, was dropped like a best-effort subscriber whenever its buffer filled
    /// (gaps in a lossless recording).
    pub(super) fn refresh_subscribers(&mut self, force: bool) {
        let mut frame = frame_subscribers(&self.frame_service);
        let mut objects = objects_subscribers(&self.objects_service);
        frame.sort_unstable();
        objects.sort_unstable();
        if force || frame != self.subscribers.0 {
            self.frame_book.set_subscribers(&frame);
            self.subscribers.0 = frame;
        }
        if force || objects != self.subscribers.1 {
            self.objects_book.set_subscribers(&objects);
            self.subscribers.1 = objects;
        }
    }

    /// How many subscribers the `frame` service has.
    pub(super) fn frame_subscriber_count(&self) -> usize {
        self.subscribers.0.len()
    }
}

pub(super) fn publish_scene<S: Simulation>(
    sim: &S,
    publisher: &Publisher<Iox, [SceneGaussian], SceneHeader>,
) -> Result<(), IpcError> {
    let n = sim.gaussian_count();
    let sample = publisher
        .loan_slice_uninit(n)
        .map_err(|e| IpcError::iox("loan scene", "scene", e))?;
    // SAFETY: the loaned chunk lives in an mmap'd shared-memory segment, which the OS zero-fills
    // on creation and which otherwise holds earlier samples: every byte is initialised, and
    // every bit pattern is a valid `SceneGaussian` (Pod). `write_scene` overwrites it all.
    let mut sample = unsafe { sample.assume_init() };
    let h = sample.user_header_mut();
    *h = SceneHeader {
        scene_generation: sim.scene_generation(),
        layout_version: LAYOUT_VERSION,
        gaussian_count: n as u32,
        object_count: sim.object_count() as u32,
        sh_degree: sim.sh_degree(),
        frame_dt_s: sim.frame_dt_s(),
        ..Default::default()
    };
    write_fixed_str(&mut h.scene_name, sim.scene_name());
    for id in 0..sim.object_count().min(MAX_NAMED_OBJECTS) {
        if let Some(name) = sim.object_name(id as u32) {
            write_fixed_str(&mut h.object_names[id], name);
        }
    }
    sim.write_scene(sample.payload_mut());
    sample
        .send()
        .map_err(|e| IpcError::iox("send scene", "scene", e))?;
    Ok(())
}

/// The header of a `frame`, `objects` or `object_names` sample of `count` elements, stamped with
/// the simulation's current step, time and generation.
fn frame_header<S: Simulation>(sim: &S, frame_index: u64, count: usize) -> FrameHeader {
    FrameHeader {
        step: sim.step(),
        time_s: sim.time_s(),
        substeps: sim.substeps(),
        frame_index,
        count: count as u32,
        scene_generation: sim.scene_generation(),
        layout_version: LAYOUT_VERSION,
        reserved: 0,
        publish_unix_ns: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64),
    }
}

/// Publishes every object's name (with the scene, once per generation).
pub(super) fn publish_object_names<S: Simulation>(
    sim: &S,
    publisher: &Publisher<Iox, [ObjectName], FrameHeader>,
) -> Result<(), IpcError> {
    let m = sim.object_count();
    let sample = publisher
        .loan_slice_uninit(m)
        .map_err(|e| IpcError::iox("loan object names", "object_names", e))?;
    // SAFETY: as in `publish_scene`: shared memory is always initialised and `ObjectName` is
    // Pod; every element is overwritten below.
    let mut sample = unsafe { sample.assume_init() };
    *sample.user_header_mut() = frame_header(sim, 0, m);
    for (id, n) in sample.payload_mut().iter_mut().enumerate() {
        *n = ObjectName::new(sim.object_name(id as u32).unwrap_or(""));
    }
    sample
        .send()
        .map_err(|e| IpcError::iox("send object names", "object_names", e))?;
    Ok(())
}

pub(super) fn publish_frame<S: Simulation>(
    sim: &S,
    ports: &Ports,
    frame_index: u64,
) -> Result<(), IpcError> {
    let header = |count: usize| frame_header(sim, frame_index, count);
    let n = sim.gaussian_count();
    let sample = ports
        .frame_pub
        .loan_slice_uninit(n)
        .map_err(|e| IpcError::iox("loan frame", &ports.names.name("frame"), e))?;
    // SAFETY: as in `publish_scene`: shared memory is always initialised and `FrameGaussian`
    // is Pod; `write_frame` overwrites every element.
    let mut sample = unsafe { sample.assume_init() };
    *sample.user_header_mut() = header(n);
    sim.write_frame(sample.payload_mut());
    ports.frame_book.begin_frame(frame_index);
    sample
        .send()
        .map_err(|e| IpcError::iox("send frame", &ports.names.name("frame"), e))?;
    ports.frame_book.end_frame(frame_index);

    let m = sim.object_count();
    let sample = ports
        .objects_pub
        .loan_slice_uninit(m)
        .map_err(|e| IpcError::iox("loan objects", &ports.names.name("objects"), e))?;
    // SAFETY: as above; `ObjectState` is Pod and `write_objects` overwrites every element.
    let mut sample = unsafe { sample.assume_init() };
    *sample.user_header_mut() = header(m);
    sim.write_objects(sample.payload_mut());
    ports.objects_book.begin_frame(frame_index);
    sample
        .send()
        .map_err(|e| IpcError::iox("send objects", &ports.names.name("objects"), e))?;
    ports.objects_book.end_frame(frame_index);
    Ok(())
}

/// The `frame` publisher as the server creates it: room for `gaussians` per sample (grows by
/// powers of two), and a full subscriber buffer handled by `book` (lossless subscribers are
/// waited for up to its limit, best-effort ones skip the frame). `splatphys bench ipc` measures
/// this very publisher.
///
/// # Errors
/// iceoryx2 failures.
pub fn frame_publisher(
    service: &FrameService,
    names: &ServiceNames,
    gaussians: usize,
    book: &LagBook,
) -> Result<Publisher<Iox, [FrameGaussian], FrameHeader>, IpcError> {
    service
        .publisher_builder()
        .initial_max_slice_len(gaussians.max(1))
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
        .set_backpressure_handler(book.handler())
        .create()
        .map_err(|e| IpcError::iox("create publisher", &names.name("frame"), e))
}

/// The `objects` publisher as the server creates it; see [`frame_publisher`].
///
/// # Errors
/// iceoryx2 failures.
pub fn objects_publisher(
    service: &ObjectsService,
    names: &ServiceNames,
    objects: usize,
    book: &LagBook,
) -> Result<Publisher<Iox, [ObjectState], FrameHeader>, IpcError> {
    service
        .publisher_builder()
        .initial_max_slice_len(objects.max(1))
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
        .set_backpressure_handler(book.handler())
        .create()
        .map_err(|e| IpcError::iox("create publisher", &names.name("objects"), e))
}

pub(super) fn clean_dead_nodes(node: &Node<Iox>) {
    // Removes the shared-memory resources of killed clients; a cleanup that is busy elsewhere
    // is simply retried next period.
    let _ = node.try_cleanup_dead_nodes();
}
