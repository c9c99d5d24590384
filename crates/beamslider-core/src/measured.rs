//! Measured runs in the published text format (docs/model.md §7: time, beam velocity and slider
//! position a line): the numbers of a file parsed at once. The checks of the rows (three a line,
//! finite, time increasing) and the line-numbered errors of any other form are the reader's
//! (`beamslider.measurement`).

/// The numbers of `text`, in order, separated by whitespace, commas or semicolons; None if a token
/// is not a number. Rust's `f64` parser rounds correctly, as Python's `float`, so the values are
/// bitwise those of a token-by-token reader.
pub fn plain_numbers(text: &str) -> Option<Vec<f64>> {
    let mut out = Vec::with_capacity(text.len() / 10);
    for tok in text.split(|c: char| c.is_whitespace() || c == ',' || c == ';').filter(|t| !t.is_empty()) {
        out.push(tok.parse::<f64>().ok()?);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_of_the_usual_forms_and_what_is_not_a_number() {
        let v = plain_numbers("0 1.5e-3 -2\n1e-4,0.25;  3.0\r\n0.0002\t-1E2 .5\n").unwrap();
        assert_eq!(v, vec![0.0, 1.5e-3, -2.0, 1e-4, 0.25, 3.0, 0.0002, -100.0, 0.5]);
        assert_eq!(plain_numbers("").unwrap(), Vec::<f64>::new());
        assert!(plain_numbers("t v s\n0 1 2\n").is_none());
        assert!(plain_numbers("0 1 2x\n").is_none());
        // Correctly rounded: the nearest double of a long decimal.
        assert_eq!(plain_numbers("0.1000000000000000055511151231257827").unwrap()[0], 0.1);
    }
}
