//! Frames of every length from 1 to two packets and one byte, exact multiples of the
//! packet size included, each written alone: the host must get each whole and without
//! waiting for more data (a transfer that ends on a full packet needs a zero-length
//! packet after it, or a host reading more than a packet at a time waits).

use brdf_core::service::Link;
use usb_link::MAX_PACKET;

use super::rig::Rig;

/// Loop iterations allowed for a frame to arrive (a liveness bound: it takes a few).
const PATIENCE: u32 = 1_000;

/// A frame of `len` bytes: non-zero bytes then the 0x00 that ends every frame.
fn frame(len: usize) -> Vec<u8> {
    (1..len)
        .map(|k| 1 + ((k * 7 + len) % 255) as u8)
        .chain([0])
        .collect()
}

fn every_length_arrives(transfer_size: usize) {
    let mut rig = Rig::new();
    rig.transfer_size = transfer_size;
    rig.open_port();
    for len in 1..=2 * MAX_PACKET + 1 {
        let sent = frame(len);
        // Handed to the link as the service loop does: what it takes now, the rest on
        // later iterations.
        let mut off = 0;
        for _ in 0..PATIENCE {
            if off == len {
                break;
            }
            off += rig.link.write(&sent[off..]);
            rig.step_both();
        }
        assert_eq!(off, len, "the link did not take a {len}-byte frame");
        for _ in 0..PATIENCE {
            if rig.received.len() >= len {
                break;
            }
            rig.step_both();
        }
        let got: Vec<u8> = rig.received.drain(..).collect();
        assert_eq!(
            got.len(),
            len,
            "a {len}-byte frame, host reading {transfer_size} bytes at a time: {} bytes \
             arrived; the rest waits in an unfinished transfer (no short or zero-length \
             packet ended it)",
            got.len()
        );
        assert_eq!(got, sent, "a {len}-byte frame arrived altered");
    }
}

#[test]
fn every_frame_length_arrives_with_linux_transfers() {
    // Linux's cdc-acm reads two packets per transfer.
    every_length_arrives(2 * MAX_PACKET);
}

#[test]
fn every_frame_length_arrives_with_long_transfers() {
    // Hosts that read larger blocks need the zero-length packet after every multiple
    // of the packet size.
    every_length_arrives(4096);
}
