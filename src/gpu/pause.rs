//! A render that can stop between two passes and go on later: the fragment kernels' ray
//! tree walk is written as `async` functions (`gpu::fragment::tree`), so the compiler turns
//! the walk, recursion and termination loops included, into a resumable state machine. It
//! suspends only where an observer answered [`Flow::Pause`](super::request::Flow::Pause)
//! after a pass; nothing else ever makes it wait.
//!
//! - [`block_on`] runs it to the end (a pause is polled straight through): the native
//!   renders and `view`, the same code with the same passes;
//! - [`Stepped`] runs it one stretch per [`Stepped::resume`]: the web page, which must
//!   return to the browser to show anything, resumes it once per animation frame.
//!
//! No executor crate: the walk never waits on I/O, so a future here is only ever polled
//! by these two, with a waker that does nothing.

use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll, Waker};

/// Polls `fut` until it is done. A pause suspends it for one poll, so this is the walk
/// without pauses.
pub fn block_on<F: Future>(fut: F) -> F::Output {
    let mut fut = std::pin::pin!(fut);
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(out) = fut.as_mut().poll(&mut cx) {
            return out;
        }
    }
}

/// Suspends the future that awaits it once: the pause point of the walk.
pub(crate) async fn pause() {
    let mut paused = false;
    std::future::poll_fn(|_| {
        if paused {
            Poll::Ready(())
        } else {
            paused = true;
            Poll::Pending
        }
    })
    .await
}

/// A render in progress that runs between pauses ([`crate::gpu::render::render_stepped`]).
/// Dropping it abandons the render and frees its GL objects, as a cancel does.
/// `T` is what it gives at the end (a render's `Result<GpuOutput>`).
pub struct Stepped<'a, T> {
    walk: Option<Pin<Box<dyn Future<Output = T> + 'a>>>,
}

impl<'a, T> Stepped<'a, T> {
    /// Wraps a render's future.
    pub(crate) fn new(walk: impl Future<Output = T> + 'a) -> Self {
        Stepped {
            walk: Some(Box::pin(walk)),
        }
    }

    /// Runs the render until its observer pauses it (`None`) or it is done (its result,
    /// once; `None` again after that).
    pub fn resume(&mut self) -> Option<T> {
        let walk = self.walk.as_mut()?;
        let mut cx = Context::from_waker(Waker::noop());
        match walk.as_mut().poll(&mut cx) {
            Poll::Pending => None,
            Poll::Ready(out) => {
                self.walk = None;
                Some(out)
            }
        }
    }

    /// Whether the render has finished (its result was returned).
    pub fn is_done(&self) -> bool {
        self.walk.is_none()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A future with two pause points: `block_on` runs it through, `Stepped` stops at each.
    #[test]
    fn block_on_runs_through_pauses_and_stepped_stops_at_each() {
        async fn two_pauses(log: &std::cell::RefCell<Vec<u32>>) -> u32 {
            log.borrow_mut().push(1);
            pause().await;
            log.borrow_mut().push(2);
            pause().await;
            log.borrow_mut().push(3);
            7
        }
        let log = std::cell::RefCell::new(Vec::new());
        assert_eq!(block_on(two_pauses(&log)), 7);
        assert_eq!(*log.borrow(), [1, 2, 3]);

        let log = std::cell::RefCell::new(Vec::new());
        let mut s = Stepped::new(two_pauses(&log));
        assert!(s.resume().is_none());
        assert_eq!(*log.borrow(), [1]);
        assert!(s.resume().is_none());
        assert_eq!(*log.borrow(), [1, 2]);
        assert_eq!(s.resume(), Some(7));
        assert_eq!(*log.borrow(), [1, 2, 3]);
        assert!(s.is_done() && s.resume().is_none());
    }
}
