//! Parsing of angle lists on the command line: `a,b,c` or `start:stop:step` (degrees).

use crate::error::{CliError, CliResult};

/// Most angles one list may expand to.
pub const MAX_ANGLES: usize = 1_000_000;

/// Parses `SPEC`: a comma-separated list of degrees, or `start:stop:step` with the stop
/// included when it falls on the grid (within 1e-9 of a step). A negative step counts down.
/// Items may mix both forms: `-80:-20:10,0,20:80:10`.
pub fn parse_angles(what: &str, spec: &str) -> CliResult<Vec<f64>> {
    let mut out = Vec::new();
    for item in spec.split(',') {
        let item = item.trim();
        if item.is_empty() {
            return Err(CliError::usage(format!("{what}: empty item in '{spec}'")));
        }
        let parts: Vec<&str> = item.split(':').collect();
        match parts.as_slice() {
            [one] => out.push(number(what, one)?),
            [start, stop, step] => range(
                what,
                number(what, start)?,
                number(what, stop)?,
                number(what, step)?,
                &mut out,
            )?,
            _ => {
                return Err(CliError::usage(format!(
                    "{what}: '{item}' is neither a number nor start:stop:step"
                )));
            }
        }
        if out.len() > MAX_ANGLES {
            return Err(CliError::usage(format!(
                "{what}: more than {MAX_ANGLES} angles"
            )));
        }
    }
    Ok(out)
}

fn number(what: &str, s: &str) -> CliResult<f64> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| CliError::usage(format!("{what}: '{s}' is not a number")))?;
    if !v.is_finite() {
        return Err(CliError::usage(format!(
            "{what}: '{s}' is not a finite number"
        )));
    }
    Ok(v)
}

fn range(what: &str, start: f64, stop: f64, step: f64, out: &mut Vec<f64>) -> CliResult {
    if step == 0.0 {
        return Err(CliError::usage(format!("{what}: step must not be 0")));
    }
    let steps = (stop - start) / step;
    if steps < -1e-9 {
        return Err(CliError::usage(format!(
            "{what}: step {step} does not lead from {start} to {stop}"
        )));
    }
    let n = (steps + 1e-9).floor();
    if n >= MAX_ANGLES as f64 {
        return Err(CliError::usage(format!(
            "{what}: more than {MAX_ANGLES} angles"
        )));
    }
    let n = n as usize;
    for k in 0..=n {
        // Computed from the start each time (no accumulated error); the stop itself is
        // exact when it lies on the grid.
        let v = if k == n && (start + k as f64 * step - stop).abs() <= 1e-9 * step.abs() {
            stop
        } else {
            start + k as f64 * step
        };
        out.push(v);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_ranges_and_mixes() {
        assert_eq!(parse_angles("t", "10").unwrap(), vec![10.0]);
        assert_eq!(parse_angles("t", "-5, 0,5").unwrap(), vec![-5.0, 0.0, 5.0]);
        let r = parse_angles("t", "-80:80:10").unwrap();
        assert_eq!(r.len(), 17);
        assert_eq!((r[0], r[8], r[16]), (-80.0, 0.0, 80.0));
        assert_eq!(parse_angles("t", "0:1:0.1").unwrap().last(), Some(&1.0));
        assert_eq!(
            parse_angles("t", "0:1:0.3").unwrap(),
            vec![0.0, 0.3, 0.6, 0.8999999999999999]
        );
        assert_eq!(
            parse_angles("t", "10:0:-5,40").unwrap(),
            vec![10.0, 5.0, 0.0, 40.0]
        );
        assert_eq!(parse_angles("t", "3:3:1").unwrap(), vec![3.0]);
    }

    #[test]
    fn bad_specs_say_what_is_wrong() {
        for (spec, msg) in [
            ("", "empty item"),
            ("1,,2", "empty item"),
            ("abc", "'abc' is not a number"),
            ("nan", "not a finite number"),
            ("0:inf:1", "not a finite number"),
            ("0:10", "neither a number nor start:stop:step"),
            ("0:10:0", "step must not be 0"),
            ("10:0:1", "does not lead from 10 to 0"),
            ("0:1e9:1e-3", "more than"),
        ] {
            let err = parse_angles("--theta-r", spec).unwrap_err();
            assert_eq!(err.code, 2);
            assert!(err.message.contains(msg), "{spec}: {}", err.message);
            assert!(err.message.starts_with("--theta-r"), "{}", err.message);
        }
    }
}
