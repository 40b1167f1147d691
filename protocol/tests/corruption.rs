//! A long stream of framed messages with random garbage, bit flips, truncations and split
//! reads: every intact frame is decoded, in order; no corrupted frame is accepted; and the
//! decoder's drop count equals the number of damaged fragments on the line.
#![allow(clippy::unwrap_used)] // tests unwrap: a failure is the test failing

mod common;

use proptest::prelude::*;
use vistaf_protocol::*;

#[derive(Debug, Clone)]
enum Damage {
    None,
    /// Garbage bytes inserted before the frame (may contain delimiters).
    GarbageBefore(Vec<u8>),
    /// Flip bit `bit` of body byte `at` (delimiters are left alone).
    FlipBit {
        at: usize,
        bit: u8,
    },
    /// Keep the leading delimiter and fewer than all body bytes.
    CutTail {
        keep: usize,
    },
    /// Drop the leading delimiter and at least one body byte.
    CutHead {
        skip: usize,
    },
}

fn arb_damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        6 => Just(Damage::None),
        1 => proptest::collection::vec(any::<u8>(), 1..80).prop_map(Damage::GarbageBefore),
        1 => proptest::collection::vec(1u8..=255, 1..300).prop_map(Damage::GarbageBefore),
        1 => (any::<usize>(), 0u8..8).prop_map(|(at, bit)| Damage::FlipBit { at, bit }),
        1 => any::<usize>().prop_map(|keep| Damage::CutTail { keep }),
        1 => any::<usize>().prop_map(|skip| Damage::CutHead { skip }),
    ]
}

/// Applies `damage` to `frame`; returns the bytes put on the line and whether the frame
/// itself reached the line unmodified.
fn apply(frame: &[u8], damage: &Damage) -> (Vec<u8>, bool) {
    let n = frame.len();
    match damage {
        Damage::None => (frame.to_vec(), true),
        Damage::GarbageBefore(g) => ([g.as_slice(), frame].concat(), true),
        Damage::FlipBit { at, bit } => {
            let mut f = frame.to_vec();
            f[1 + at % (n - 2)] ^= 1 << bit;
            (f, false)
        }
        Damage::CutTail { keep } => (frame[..1 + keep % (n - 2)].to_vec(), false),
        Damage::CutHead { skip } => (frame[2 + skip % (n - 2)..].to_vec(), false),
    }
}

/// The COBS-decoded bytes of a frame body, if it is valid COBS.
fn unstuffed(body: &[u8]) -> Option<Vec<u8>> {
    let mut data = body.to_vec();
    let n = cobs::decode_in_place(&mut data).ok()?;
    data.truncate(n);
    Some(data)
}

fn non_empty_segments(stream: &[u8]) -> usize {
    stream.split(|&b| b == 0).filter(|s| !s.is_empty()).count()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(
        std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256)
    ))]

    #[test]
    fn intact_frames_survive_and_damaged_ones_are_counted(
        plan in proptest::collection::vec((common::arb_device_msg(), arb_damage()), 1..120),
        cuts in proptest::collection::vec(1usize..97, 1..50),
    ) {
        let mut stream = Vec::new();
        let mut intact = Vec::new();
        let mut bodies: Vec<(Vec<u8>, DeviceMsg)> = Vec::new();
        for (msg, damage) in &plan {
            let f = common::frame(msg);
            bodies.push((unstuffed(&f[1..f.len() - 1]).unwrap(), msg.clone()));
            let (bytes, ok) = apply(&f, damage);
            stream.extend_from_slice(&bytes);
            if ok {
                intact.push(msg.clone());
            }
        }
        // What the line holds: every fragment that unstuffs to the bytes of a frame. That is
        // each intact frame; a frame cut only by its redundant last code byte (see
        // `frame_len_max`); and a damaged frame's head spliced onto a later frame's tail when
        // together they spell a whole valid frame (identical messages cut at the same byte):
        // frames on the line, not corruption.
        let on_line: Vec<DeviceMsg> = stream
            .split(|&b| b == 0)
            .filter_map(|seg| {
                let data = unstuffed(seg)?;
                bodies.iter().find(|(b, _)| *b == data).map(|(_, m)| m.clone())
            })
            .collect();
        let mut dec = DeviceDecoder::new();
        let mut got = Vec::new();
        let mut errors = 0u64;
        let mut rest = stream.as_slice();
        for cut in cuts.iter().cycle() {
            if rest.is_empty() { break; }
            let (now, later) = rest.split_at((*cut).min(rest.len()));
            dec.push(now, |r| match r {
                Ok(m) => got.push(m),
                Err(_) => errors += 1,
            });
            rest = later;
        }
        if dec.finish().is_some() {
            errors += 1;
        }
        // Exactly the frames on the line, in order: nothing lost, nothing corrupted accepted;
        // and every intact frame is among them.
        prop_assert_eq!(&got, &on_line);
        let mut rest = got.iter();
        for m in &intact {
            prop_assert!(rest.any(|g| g == m), "intact {:?} was not decoded", m);
        }
        // Every other fragment on the line is one counted drop.
        let fragments = non_empty_segments(&stream) as u64;
        prop_assert_eq!(dec.drops().total(), fragments - on_line.len() as u64);
        prop_assert_eq!(errors, dec.drops().total());
        prop_assert_eq!(dec.accepted(), on_line.len() as u64);
    }
}

#[test]
fn long_noisy_stream_loses_only_damaged_frames() {
    // Deterministic large case: 20 000 summaries, every 7th damaged in turn.
    let mut stream = Vec::new();
    let mut intact = Vec::new();
    let mut rng = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    for seq in 0..20_000u32 {
        let msg = DeviceMsg::Summary(Summary {
            seq,
            force_mn: seq * 3,
            ..common::contact_summary()
        });
        let damage = match (seq % 7, seq / 7 % 4) {
            (0, 0) => Damage::GarbageBefore((0..next() % 40).map(|_| next() as u8).collect()),
            (0, 1) => Damage::FlipBit {
                at: next() as usize,
                bit: (next() % 8) as u8,
            },
            (0, 2) => Damage::CutTail {
                keep: next() as usize,
            },
            (0, 3) => Damage::CutHead {
                skip: next() as usize,
            },
            _ => Damage::None,
        };
        let (bytes, ok) = apply(&common::frame(&msg), &damage);
        stream.extend_from_slice(&bytes);
        if ok {
            intact.push(msg);
        }
    }
    let mut dec = DeviceDecoder::new();
    let mut got = Vec::new();
    for chunk in stream.chunks(61) {
        dec.push(chunk, |r| {
            if let Ok(m) = r {
                got.push(m)
            }
        });
    }
    assert_eq!(got.len(), intact.len());
    assert!(got == intact);
    assert_eq!(
        dec.drops().total(),
        non_empty_segments(&stream) as u64 - intact.len() as u64
    );
}
