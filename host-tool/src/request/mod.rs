//! The one front door of fitting: a [`Request`] (typed values, or the words of the
//! command line and Python: [`Words`]) resolved once, with a sweep's own `#` lines,
//! into a [`fit::job::Job`] whose units, aperture, offset, instrument, floor and noise
//! model are final; `gonio fit`, `demo`, campaigns and Python all come through here,
//! then [`fit::job::run`], then [`render`].

pub mod render;
mod resolve;
mod words;

pub use resolve::{Aperture, InstrumentFile, Request};
pub use words::Words;

#[cfg(test)]
mod tests;
