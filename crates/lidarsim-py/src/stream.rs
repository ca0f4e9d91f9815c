//! Runs that stream: the simulation on a thread of its own hands the points
//! to Python in blocks through a queue of bounded length, so a flight of
//! any length runs in the memory of a few blocks. The simulator's writer
//! waits while the queue is full and its workers stay at most a few blocks
//! ahead of it, so nothing piles up when Python is slow to take them.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, sync_channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use lidarsim::Flight;
use lidarsim::output::{LasSettings, PointRecord, PointSink, WriteCause};
use lidarsim::sim::{RunControl, Simulator};
use numpy::PyArray1;
use pyo3::exceptions::{PyRuntimeError, PyStopIteration};
use pyo3::prelude::*;

use crate::errors::point_error;
use crate::hold::Hold;
use crate::points::{RECORD_BYTES, pack};

/// Blocks waiting in the queue at most.
const QUEUE: usize = 2;

/// How often a waiting `__next__` looks at Python's signals.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// A sink that packs points and sends them on once a block holds at least
/// `min_points`.
struct QueueSink {
    settings: LasSettings,
    min_points: usize,
    bytes: Vec<u8>,
    tx: SyncSender<Vec<u8>>,
}

/// Why a stream's simulation ended early.
#[derive(Debug)]
enum StreamEnd {
    /// The stream was closed (the receiver is gone): stop quietly.
    Closed,
    /// A point the LAS scale and offset cannot store.
    Point(WriteCause),
}

impl QueueSink {
    fn send(&mut self) -> Result<(), StreamEnd> {
        let block = std::mem::take(&mut self.bytes);
        self.tx.send(block).map_err(|_| StreamEnd::Closed)
    }
}

impl PointSink for QueueSink {
    type Error = StreamEnd;

    fn write(&mut self, points: &[PointRecord]) -> Result<(), StreamEnd> {
        for p in points {
            pack(&self.settings, p, &mut self.bytes).map_err(StreamEnd::Point)?;
        }
        if self.bytes.len() >= self.min_points * RECORD_BYTES {
            self.send()?;
        }
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<(), StreamEnd> {
        if !self.bytes.is_empty() {
            self.send()?;
        }
        Ok(())
    }

    fn discard(self: Box<Self>) {}
}

/// An iterator over blocks of packed points (`uint8` arrays of whole
/// records), in pulse order; `pulses_done` counts the pulse slots
/// simulated so far.
#[pyclass(module = "lidarsim._lidarsim")]
pub struct PointStream {
    rx: Mutex<Option<Receiver<Vec<u8>>>>,
    stop: Arc<AtomicBool>,
    done: Arc<AtomicU64>,
    worker: Mutex<Option<JoinHandle<Result<(), StreamEnd>>>>,
    total: u64,
}

impl PointStream {
    /// Starts simulating `flight` on `threads` threads, blocks of at
    /// least `min_points` points.
    pub fn start(flight: Arc<Flight>, threads: usize, min_points: usize) -> Self {
        let (tx, rx) = sync_channel(QUEUE);
        let stop = Arc::new(AtomicBool::new(false));
        let done = Arc::new(AtomicU64::new(0));
        let total = flight.pulses();
        let settings = flight.las_settings();
        let (stop_flag, counter) = (Arc::clone(&stop), Arc::clone(&done));
        let worker = std::thread::spawn(move || {
            let sim = Simulator::new(flight.survey(), flight.world());
            let mut sink = Box::new(QueueSink {
                settings,
                min_points: min_points.max(1),
                bytes: Vec::new(),
                tx,
            });
            let control = RunControl {
                start: Default::default(),
                stop: Some(&stop_flag),
                pulse_budget: None,
                only: None,
            };
            let hold = Hold::from_env();
            let progress = |n: u64| {
                counter.store(n, Ordering::SeqCst);
                let held = hold.as_ref().map_or(Ok(()), |h| {
                    h.wait(n, || stop_flag.load(Ordering::SeqCst), || {})
                });
                if let Err(e) = held {
                    // The stream ends early: a test that meant to stop it
                    // sees it end instead, and fails.
                    eprintln!("{e}");
                    stop_flag.store(true, Ordering::SeqCst);
                }
            };
            {
                let mut sinks: [&mut (dyn PointSink<Error = StreamEnd> + 'static); 1] =
                    [sink.as_mut()];
                sim.run_from(threads, &mut sinks, &progress, &control)?;
            }
            sink.finish()
        });
        Self {
            rx: Mutex::new(Some(rx)),
            stop,
            done,
            worker: Mutex::new(Some(worker)),
            total,
        }
    }

    /// Stops the simulation and waits for its thread; its error, unless it
    /// only noticed that the stream was closed.
    fn shut(&self, py: Python<'_>) -> PyResult<()> {
        self.stop.store(true, Ordering::SeqCst);
        // Dropping the receiver wakes a sender waiting on a full queue.
        drop(self.rx.lock().expect("stream lock").take());
        let Some(worker) = self.worker.lock().expect("stream lock").take() else {
            return Ok(());
        };
        match py.detach(|| worker.join()) {
            Ok(Ok(())) => Ok(()),
            Ok(Err(StreamEnd::Closed)) => Ok(()),
            Ok(Err(StreamEnd::Point(e))) => Err(point_error(&e)),
            Err(_) => Err(PyRuntimeError::new_err("the simulation thread panicked")),
        }
    }
}

#[pymethods]
impl PointStream {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    /// The next block, waiting for it with the GIL released; Ctrl-C stops
    /// the simulation and raises `KeyboardInterrupt`.
    fn __next__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<u8>>> {
        loop {
            // The receiver is taken out while waiting (it is not `Sync`)
            // and put back after.
            let Some(rx) = self.rx.lock().expect("stream lock").take() else {
                return Err(PyStopIteration::new_err(()));
            };
            let (rx, got) = py.detach(move || {
                let got = rx.recv_timeout(SIGNAL_POLL);
                (rx, got)
            });
            *self.rx.lock().expect("stream lock") = Some(rx);
            match got {
                Ok(block) => return Ok(PyArray1::from_vec(py, block)),
                Err(RecvTimeoutError::Timeout) => {
                    if let Err(e) = py.check_signals() {
                        self.shut(py)?;
                        return Err(e);
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    self.shut(py)?;
                    return Err(PyStopIteration::new_err(()));
                }
            }
        }
    }

    /// Stops the simulation (a stream left early).
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        self.shut(py)
    }

    /// Pulse slots simulated so far.
    #[getter]
    fn pulses_done(&self) -> u64 {
        self.done.load(Ordering::SeqCst)
    }

    /// Pulse slots of the whole survey.
    #[getter]
    fn pulses_total(&self) -> u64 {
        self.total
    }
}

impl Drop for PointStream {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        drop(self.rx.get_mut().ok().and_then(Option::take));
        if let Some(worker) = self.worker.get_mut().ok().and_then(Option::take) {
            let _ = worker.join();
        }
    }
}
