//! Tests of framing: round trips of every message, and a decoder that survives noise.

use super::*;
use crate::protocol::*;
use proptest::prelude::*;
use std::format;
use std::string::String;
use std::vec::Vec as StdVec;

const N: usize = MAX_FRAME_LEN;

/// One example of every command and event (also used by the protocol doc test).
pub fn every_message() -> (StdVec<Command>, StdVec<Event>) {
    let plan = SweepPlan {
        sweep_id: 7,
        grid: Grid::Paper,
        exclude_retro_deg: 0.0,
        settings: PointSettings {
            settle_ms: 50,
            samples: 4,
            dark: false,
        },
        skip: 0,
    };
    let custom = SweepPlan {
        grid: Grid::Custom {
            incidences: heapless::Vec::from_slice(&[20.0, 40.0]).unwrap(),
            start: -80.0,
            stop: 80.0,
            step: 5.0,
        },
        exclude_retro_deg: 3.0,
        ..plan.clone()
    };
    let points = SweepPlan {
        grid: Grid::Points(
            heapless::Vec::from_slice(&[
                Point {
                    theta_i: 20.0,
                    theta_r: 19.5,
                },
                Point {
                    theta_i: 20.0,
                    theta_r: 20.5,
                },
            ])
            .unwrap(),
        ),
        settings: PointSettings {
            settle_ms: 0,
            samples: 1,
            dark: true,
        },
        skip: 1,
        ..plan.clone()
    };
    let limits = ArmLimits {
        min_deg: -90.0,
        max_deg: 90.0,
        steps_per_deg: 80.0,
    };
    // The reference mechanics' defaults, the detector's driver at 1/8 microsteps.
    let mut settings = crate::controller::settings::defaults(
        &crate::mechanics::SOURCE,
        &crate::mechanics::DETECTOR,
    );
    settings.detector.microsteps = 8;
    let commands = vec![
        Command::GetInfo,
        Command::Ping(0xDEADBEEF),
        Command::StartSweep(plan),
        Command::StartSweep(custom),
        Command::StartSweep(points),
        Command::Abort,
        Command::Home,
        Command::Jog {
            arm: Arm::Detector,
            degrees: -12.5,
        },
        Command::SetLaser(true),
        Command::Mount(Specimen::Reference),
        Command::GetStatus,
        Command::GetSettings,
        Command::SetSettings(settings),
    ];
    let events = vec![
        Event::Info(Info {
            protocol: PROTOCOL_VERSION,
            firmware: [0, 1, 0],
            board: heapless::String::try_from("qemu").unwrap(),
            source: ArmLimits {
                min_deg: 0.0,
                max_deg: 90.0,
                steps_per_deg: 80.0,
            },
            detector: limits,
            max_points: MAX_SWEEP_POINTS,
            homed: true,
        }),
        Event::Pong(0xDEADBEEF),
        Event::Reading(Reading {
            sweep_id: 7,
            seq: 41,
            theta_i: 20.0,
            theta_r: -20.0,
            value: 482.19,
            std: 2.4,
            n: 4,
            t_ms: 12345,
        }),
        Event::Progress(Progress {
            sweep_id: 7,
            done: 34,
            total: 153,
            theta_i: 20.0,
        }),
        Event::SweepDone(SweepDone {
            sweep_id: 7,
            count: 153,
            next_seq: 153,
            aborted: false,
        }),
        Event::Error(ErrorEvent::new(ErrorCode::Busy, "a sweep is running")),
        Event::Status(Status {
            source_deg: 20.0,
            detector_deg: -20.0,
            laser: true,
            homed: true,
        }),
        Event::DeviceStatus(DeviceStatus {
            source_deg: 0.0,
            detector_deg: -90.0,
            laser: false,
            homed: false,
            position_lost: true,
            interlock_open: false,
            busy: false,
            last_safe: Some(SafeReason::HostSilent),
            reset_cause: ResetCause::Watchdog,
            lease_ms: HOST_LEASE_MS,
        }),
        Event::Error(ErrorEvent::new(
            ErrorCode::HostSilent,
            "host silent: laser off, motion stopped",
        )),
        Event::Saturated(crate::protocol::Saturated {
            sweep_id: 7,
            seq: 42,
            conversions: 64,
        }),
        Event::Settings(settings),
        Event::Error(ErrorEvent::new(
            ErrorCode::BadSettings,
            "microsteps must be 1, 2, 4, .., 256",
        )),
    ];
    (commands, events)
}

fn frame<T: Serialize>(msg: &T) -> StdVec<u8> {
    let mut buf = [0u8; N];
    let n = encode(msg, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn decode_all<T: DeserializeOwned>(bytes: &[u8]) -> (StdVec<T>, FrameStats) {
    let mut d = FrameDecoder::<N>::new();
    let out = bytes
        .iter()
        .filter_map(|&b| d.push::<T>(b))
        .filter_map(Result::ok)
        .collect();
    (out, d.stats())
}

#[test]
fn every_message_round_trips() {
    let (commands, events) = every_message();
    for c in &commands {
        let f = frame(c);
        assert_eq!(*f.last().unwrap(), 0);
        assert!(
            !f[..f.len() - 1].contains(&0),
            "COBS body must be free of 0x00"
        );
        assert_eq!(decode_all::<Command>(&f).0, vec![c.clone()]);
    }
    for e in &events {
        assert_eq!(decode_all::<Event>(&frame(e)).0, vec![e.clone()]);
    }
}

#[test]
fn largest_plan_fits_the_frame_buffer() {
    let pts: heapless::Vec<Point, MAX_PLAN_POINTS> = (0..MAX_PLAN_POINTS)
        .map(|i| Point {
            theta_i: 80.0,
            theta_r: -79.5 + i as f32 * 0.1,
        })
        .collect();
    let plan = SweepPlan {
        sweep_id: u32::MAX,
        grid: Grid::Points(pts),
        exclude_retro_deg: 1.0,
        settings: PointSettings {
            settle_ms: u16::MAX,
            samples: u16::MAX,
            dark: true,
        },
        skip: u16::MAX,
    };
    let f = frame(&Command::StartSweep(plan.clone()));
    assert!(f.len() <= N, "{} > {N}", f.len());
    assert_eq!(decode_all::<Command>(&f).0, vec![Command::StartSweep(plan)]);
}

#[test]
fn small_buffer_is_an_error_not_a_panic() {
    let mut buf = [0u8; 8];
    let (_, events) = every_message();
    assert_eq!(encode(&events[0], &mut buf), Err(FrameError::BufferFull));
    assert_eq!(
        encode(&Command::Abort, &mut []),
        Err(FrameError::BufferFull)
    );
}

#[test]
fn distinguishes_corruption_from_unknown_messages() {
    // An intact frame of a different message type: CRC fine, decode fails.
    let f = frame(&(250u8, 1u8));
    let mut d = FrameDecoder::<N>::new();
    let r: StdVec<_> = f.iter().filter_map(|&b| d.push::<Command>(b)).collect();
    assert_eq!(r, vec![Err(FrameError::Decode)]);
    // One flipped bit: CRC (or COBS) failure.
    let mut f = frame(&Command::Ping(5));
    f[2] ^= 0x10;
    let r: StdVec<_> = f.iter().filter_map(|&b| d.push::<Command>(b)).collect();
    assert!(
        matches!(r.as_slice(), [Err(FrameError::Crc | FrameError::Cobs)]),
        "{r:?}"
    );
    // Trailing bytes after a valid message are not accepted either.
    let mut body = postcard::to_allocvec(&Command::Ping(5)).unwrap();
    body.push(0x42);
    let crc = CRC.checksum(&body).to_le_bytes();
    body.extend_from_slice(&crc);
    let mut enc = cobs::encode_vec(&body);
    enc.push(0);
    let r: StdVec<_> = enc.iter().filter_map(|&b| d.push::<Command>(b)).collect();
    assert_eq!(r, vec![Err(FrameError::Decode)]);
    assert_eq!(d.stats().decode, 2);
}

#[test]
fn too_long_frame_is_dropped_and_decoder_resyncs() {
    let mut d = FrameDecoder::<32>::new();
    let mut bytes = vec![0x55u8; 100];
    bytes.push(0);
    bytes.extend(frame(&Command::Ping(9)));
    let r: StdVec<_> = bytes.iter().filter_map(|&b| d.push::<Command>(b)).collect();
    assert_eq!(r, vec![Err(FrameError::TooLong), Ok(Command::Ping(9))]);
    assert_eq!(d.stats().too_long, 1);
    assert_eq!(d.stats().ok, 1);
}

#[test]
fn empty_frames_are_ignored() {
    let mut bytes = vec![0, 0, 0];
    bytes.extend(frame(&Command::Home));
    let (msgs, stats) = decode_all::<Command>(&bytes);
    assert_eq!(msgs, vec![Command::Home]);
    assert_eq!(stats.dropped(), 0);
}

fn any_command() -> impl Strategy<Value = Command> {
    let (commands, _) = every_message();
    prop::sample::select(commands)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn random_bytes_never_panic_and_resync(noise in prop::collection::vec(any::<u8>(), 0..3000), c in any_command()) {
        let mut d = FrameDecoder::<N>::new();
        for &b in &noise {
            let _ = d.push::<Command>(b);
        }
        // A 0x00 ends whatever the noise left; the next frame then decodes.
        let mut tail = vec![0u8];
        tail.extend(frame(&c));
        let got: StdVec<_> = tail.iter().filter_map(|&b| d.push::<Command>(b)).filter_map(Result::ok).collect();
        prop_assert_eq!(got, vec![c]);
    }

    #[test]
    fn flipped_bits_are_never_accepted(c in any_command(), flips in prop::collection::vec((any::<prop::sample::Index>(), 0u8..8), 1..4)) {
        let good = frame(&c);
        let mut bad = good.clone();
        for (i, bit) in &flips {
            let k = i.index(bad.len() - 1); // leave the final 0x00 alone
            bad[k] ^= 1 << bit;
        }
        prop_assume!(bad != good);
        let (msgs, _) = decode_all::<Command>(&bad);
        // Whatever decodes must be the original (a flip pair can cancel out) - never a
        // different, corrupted message.
        for m in msgs {
            prop_assert_eq!(&m, &c);
        }
    }

    #[test]
    fn truncated_and_concatenated_frames(cs in prop::collection::vec(any_command(), 1..6), cut in any::<prop::sample::Index>()) {
        let mut stream = StdVec::new();
        for c in &cs {
            stream.extend(frame(c));
        }
        // Concatenated: all decode in order.
        prop_assert_eq!(decode_all::<Command>(&stream).0, cs.clone());
        // Truncated at any byte: every frame that ended before the cut decodes, none after.
        let k = cut.index(stream.len());
        let complete = stream[..k].iter().filter(|&&b| b == 0).count();
        let (msgs, stats) = decode_all::<Command>(&stream[..k]);
        prop_assert_eq!(msgs, cs[..complete].to_vec());
        prop_assert_eq!(stats.dropped(), 0);
    }
}

/// The examples section of docs/protocol.md, generated from `every_message`.
fn doc_examples() -> String {
    use std::fmt::Write;
    fn hex(b: &[u8]) -> String {
        b.iter()
            .map(|x| format!("{x:02x}"))
            .collect::<StdVec<_>>()
            .join(" ")
    }
    fn one<T: Serialize + core::fmt::Debug>(out: &mut String, msg: &T) {
        let body = postcard::to_allocvec(msg).unwrap();
        let crc = CRC.checksum(&body);
        writeln!(out, "`{msg:?}`\n").unwrap();
        writeln!(out, "    postcard  {}", hex(&body)).unwrap();
        writeln!(
            out,
            "    crc32     {crc:08x} (sent as {})",
            hex(&crc.to_le_bytes())
        )
        .unwrap();
        writeln!(out, "    frame     {}\n", hex(&frame(msg))).unwrap();
    }
    let (commands, events) = every_message();
    let mut out = String::from(
        "<!-- generated by brdf-core frame_tests::protocol_doc_is_current; do not edit -->\n\n",
    );
    out.push_str("### Commands (host to device)\n\n");
    for c in &commands {
        one(&mut out, c);
    }
    out.push_str("### Events (device to host)\n\n");
    for e in &events {
        one(&mut out, e);
    }
    out
}

#[test]
fn protocol_doc_is_current() {
    const BEGIN: &str = "<!-- examples:begin -->\n";
    const END: &str = "<!-- examples:end -->";
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/protocol.md");
    let doc = std::fs::read_to_string(&path).expect("docs/protocol.md");
    let (a, rest) = doc.split_once(BEGIN).expect("examples:begin marker");
    let (current, b) = rest.split_once(END).expect("examples:end marker");
    let fresh = doc_examples();
    if current != fresh {
        if std::env::var_os("GONIO_BLESS").is_some() {
            std::fs::write(&path, format!("{a}{BEGIN}{fresh}{END}{b}")).unwrap();
        } else {
            panic!(
                "docs/protocol.md examples are stale: run `GONIO_BLESS=1 cargo test -p brdf-core protocol_doc`"
            );
        }
    }
}

#[test]
fn crc_is_the_standard_crc32() {
    // The check value every CRC-32/ISO-HDLC implementation (zlib, Python's
    // binascii.crc32) gives for ASCII "123456789", as docs/protocol.md states.
    assert_eq!(CRC.checksum(b"123456789"), 0xCBF4_3926);
}

#[test]
fn a_newer_info_still_shows_its_version() {
    // A hypothetical newer Info: variant 0, protocol first, then fields this one does
    // not know.
    let v2 = (
        0u8,
        PROTOCOL_VERSION + 1,
        [9u8; 5],
        "board with a longer name than v1 allows!",
    );
    let mut d = FrameDecoder::<N>::new();
    let r: StdVec<_> = frame(&v2)
        .iter()
        .filter_map(|&b| d.push::<Event>(b))
        .collect();
    assert_eq!(r, vec![Err(FrameError::Decode)]);
    assert_eq!(
        peek_info_version(d.undecoded_payload()),
        Some(PROTOCOL_VERSION + 1)
    );
    // An ordinary Info peeks the same way; another event does not.
    let (_, events) = every_message();
    assert_eq!(
        peek_info_version(&postcard::to_allocvec(&events[0]).unwrap()),
        Some(PROTOCOL_VERSION)
    );
    assert_eq!(
        peek_info_version(&postcard::to_allocvec(&events[1]).unwrap()),
        None
    );
    // The payload is only offered right after the failed frame.
    d.push::<Event>(0x11);
    assert!(d.undecoded_payload().is_empty());
}
