//! Who sets each step of a session and is told how it went: a person at a terminal, the
//! `--plan` script, and a load cell's indicator that answers the force steps.

use std::io::{BufRead, Write};

use vistaf_protocol::{KitQuantity, KitStep};

use crate::scale::Scale;

/// What a person answers to a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Answer {
    /// Set as asked: capture with the planned value.
    Ready,
    /// Set, but the reading differs: capture with this value (mm, N or °C).
    Measured(f64),
    /// Leave this step out.
    Skip,
    /// End the session without fitting.
    Quit,
}

/// Who sets each step and is told how it went.
pub trait Guide {
    /// Asks for `step` (`n` of `total`); the answer.
    fn ask(&mut self, step: &KitStep, n: usize, total: usize) -> Answer;
    /// Tells something.
    fn say(&mut self, text: &str);
}

impl<G: Guide + ?Sized> Guide for Box<G> {
    fn ask(&mut self, step: &KitStep, n: usize, total: usize) -> Answer {
        (**self).ask(step, n, total)
    }

    fn say(&mut self, text: &str) {
        (**self).say(text);
    }
}

/// A person at a terminal: each step asked for, Enter to capture.
#[derive(Debug)]
pub struct Terminal<R: BufRead, W: Write> {
    input: R,
    out: W,
}

impl<R: BufRead, W: Write> Terminal<R, W> {
    /// Reads answers from `input`, writes prompts to `out`.
    pub fn new(input: R, out: W) -> Terminal<R, W> {
        Terminal { input, out }
    }
}

/// What to do for a step, in words.
pub fn instruction(step: &KitStep) -> String {
    let v = f64::from(step.value_milli) / 1000.0;
    match step.quantity {
        KitQuantity::Reference => {
            format!("leave the skin untouched at {v:.1} °C (the kit's reference)")
        }
        KitQuantity::Depth => format!("press the 10 mm sphere to {v:.2} mm"),
        KitQuantity::Force => format!("press the 10 mm sphere until the load cell reads {v:.1} N"),
        KitQuantity::Temperature => {
            format!("bring the untouched skin to {v:.1} °C and let it settle")
        }
    }
}

impl<R: BufRead, W: Write> Guide for Terminal<R, W> {
    fn ask(&mut self, step: &KitStep, n: usize, total: usize) -> Answer {
        let (_, unit, _) = step.quantity.si();
        loop {
            let _ = write!(
                self.out,
                "[{n}/{total}] {}, then Enter (or type the reading in {unit}; s skips, q quits): ",
                instruction(step)
            );
            let _ = self.out.flush();
            let mut line = String::new();
            match self.input.read_line(&mut line) {
                Ok(0) | Err(_) => return Answer::Quit,
                Ok(_) => {}
            }
            match line.trim() {
                "" => return Answer::Ready,
                "s" => return Answer::Skip,
                "q" => return Answer::Quit,
                t => match t.parse::<f64>() {
                    Ok(v) if v.is_finite() => return Answer::Measured(v),
                    _ => {
                        let _ = writeln!(self.out, "  {t:?}: a number in {unit}, s or q");
                    }
                },
            }
        }
    }

    fn say(&mut self, text: &str) {
        let _ = writeln!(self.out, "{text}");
    }
}

/// The `--plan` mode: every step taken as planned (the bench is driven by the device or
/// the heater command), progress written to `out`.
#[derive(Debug)]
pub struct Scripted<W: Write> {
    out: W,
}

impl<W: Write> Scripted<W> {
    /// Writes progress to `out`.
    pub fn new(out: W) -> Scripted<W> {
        Scripted { out }
    }
}

impl<W: Write> Guide for Scripted<W> {
    fn ask(&mut self, step: &KitStep, n: usize, total: usize) -> Answer {
        let _ = writeln!(self.out, "[{n}/{total}] {}", instruction(step));
        Answer::Ready
    }

    fn say(&mut self, text: &str) {
        let _ = writeln!(self.out, "{text}");
    }
}

/// A guide whose force steps take their value from a scale: when the step is set as asked,
/// the scale is read and its reading is the step's value (a reading typed in still wins).
pub struct WithScale<G: Guide> {
    inner: G,
    scale: Box<dyn Scale>,
}

impl<G: Guide> std::fmt::Debug for WithScale<G> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WithScale").finish_non_exhaustive()
    }
}

impl<G: Guide> WithScale<G> {
    /// Asks through `inner`, reading `scale` for force steps.
    pub fn new(inner: G, scale: Box<dyn Scale>) -> WithScale<G> {
        WithScale { inner, scale }
    }
}

/// Attempts at reading the scale before a session ends.
const SCALE_ATTEMPTS: usize = 3;

impl<G: Guide> Guide for WithScale<G> {
    fn ask(&mut self, step: &KitStep, n: usize, total: usize) -> Answer {
        for _ in 0..SCALE_ATTEMPTS {
            let answer = self.inner.ask(step, n, total);
            if step.quantity != KitQuantity::Force || answer != Answer::Ready {
                return answer;
            }
            match self.scale.read_n() {
                Ok(force_n) => {
                    self.inner.say(&format!("  the scale reads {force_n:.3} N"));
                    return Answer::Measured(force_n);
                }
                Err(e) => self.inner.say(&format!("  {e}")),
            }
        }
        self.inner
            .say("the scale gave no reading: ending the session (the frames so far are kept)");
        Answer::Quit
    }

    fn say(&mut self, text: &str) {
        self.inner.say(text);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scale that reads what it is given, then fails.
    struct Readings(Vec<f64>);

    impl Scale for Readings {
        fn read_n(&mut self) -> Result<f64, String> {
            self.0
                .pop()
                .ok_or_else(|| "scale /dev/null: 0 readings".to_string())
        }
    }

    #[test]
    fn a_force_step_takes_the_scale_reading_and_other_steps_do_not() {
        let step = |quantity, value_milli| KitStep {
            quantity,
            value_milli,
        };
        let mut out = Vec::new();
        let mut g = WithScale::new(Scripted::new(&mut out), Box::new(Readings(vec![6.02])));
        let depth = step(KitQuantity::Depth, 500);
        let force = step(KitQuantity::Force, 6_000);
        assert_eq!(g.ask(&depth, 1, 3), Answer::Ready);
        assert_eq!(g.ask(&force, 2, 3), Answer::Measured(6.02));
        assert_eq!(g.ask(&force, 3, 3), Answer::Quit, "no reading, three times");
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("the scale reads 6.020 N"), "{text}");
        assert_eq!(text.matches("0 readings").count(), SCALE_ATTEMPTS);
        // A typed reading wins over the scale.
        let mut g = WithScale::new(
            Terminal::new(&b"5.9\n"[..], Vec::new()),
            Box::new(Readings(vec![6.02])),
        );
        assert_eq!(g.ask(&force, 1, 1), Answer::Measured(5.9));
    }

    #[test]
    fn a_terminal_takes_enter_a_reading_skip_and_quit() {
        let input = b"\n0.52\nnope\ns\nq\n";
        let mut out = Vec::new();
        let mut t = Terminal::new(&input[..], &mut out);
        let step = KitStep {
            quantity: KitQuantity::Depth,
            value_milli: 500,
        };
        assert_eq!(t.ask(&step, 1, 3), Answer::Ready);
        assert_eq!(t.ask(&step, 2, 3), Answer::Measured(0.52));
        assert_eq!(t.ask(&step, 3, 3), Answer::Skip);
        assert_eq!(t.ask(&step, 3, 3), Answer::Quit);
        assert_eq!(t.ask(&step, 3, 3), Answer::Quit, "end of input quits");
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("press the 10 mm sphere to 0.50 mm") && text.contains("\"nope\""));
    }
}
