//! Sequence-gap accounting: how many summaries a device sent that never arrived.

/// Counts received, missing, repeated and out-of-order sequence numbers of one device.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SeqTracker {
    next: Option<u32>,
    /// Summaries received.
    pub received: u64,
    /// Sequence numbers skipped (summaries lost on the way, or dropped by the device).
    pub missing: u64,
    /// Summaries whose number was not above the last one (a device restart resets this
    /// tracker's expectation instead; see [`SeqTracker::observe`]).
    pub out_of_order: u64,
}

/// A device whose sequence jumps back by more than this is taken to have restarted.
const RESTART_JUMP: u32 = 1 << 20;

impl SeqTracker {
    /// Records one received sequence number.
    pub fn observe(&mut self, seq: u32) {
        self.received += 1;
        match self.next {
            None => {}
            Some(expected) if seq >= expected => self.missing += u64::from(seq - expected),
            Some(expected) if expected - seq > RESTART_JUMP || seq == 0 => {}
            Some(_) => {
                self.out_of_order += 1;
                return;
            }
        }
        self.next = Some(seq.wrapping_add(1));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_and_disorder_are_counted() {
        let mut t = SeqTracker::default();
        for s in [10, 11, 14, 15, 13, 16, 0, 1] {
            t.observe(s);
        }
        assert_eq!(t.received, 8);
        assert_eq!(t.missing, 2, "12 and 13 were skipped when 14 arrived");
        assert_eq!(t.out_of_order, 1, "13 arrived late");
    }
}
