//! Bytes into the frame decoder as commands and as events: never panics, and every decoded message re-encodes to a frame that decodes to the same message.
#![no_main]

use brdf_core::frame::{FrameDecoder, MAX_FRAME_LEN, encode};
use brdf_core::protocol::{Command, Event};
use libfuzzer_sys::fuzz_target;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// Encodes `m`, decodes the frame, and checks the result encodes identically (bytes are
/// compared, not values: a NaN angle is the same message but not `==` to itself).
fn round_trip<T: Serialize + DeserializeOwned>(m: &T) {
    let mut a = [0u8; MAX_FRAME_LEN];
    let n = encode(m, &mut a).expect("a decoded message re-encodes");
    let mut d = FrameDecoder::<MAX_FRAME_LEN>::new();
    let mut back = None;
    for &b in &a[..n] {
        if let Some(r) = d.push::<T>(b) {
            back = Some(r.expect("a re-encoded frame decodes"));
        }
    }
    let back = back.expect("the frame ends with 0x00");
    let mut b = [0u8; MAX_FRAME_LEN];
    let m2 = encode(&back, &mut b).expect("re-encodes again");
    assert_eq!(&a[..n], &b[..m2], "decode(encode(m)) differs from m");
}

fuzz_target!(|data: &[u8]| {
    let mut commands = FrameDecoder::<MAX_FRAME_LEN>::new();
    let mut events = FrameDecoder::<MAX_FRAME_LEN>::new();
    for &b in data {
        if let Some(Ok(c)) = commands.push::<Command>(b) {
            round_trip(&c);
        }
        if let Some(Ok(e)) = events.push::<Event>(b) {
            round_trip(&e);
        }
    }
    let s = commands.stats();
    assert!(s.ok + s.dropped() <= data.len() as u32);
});
