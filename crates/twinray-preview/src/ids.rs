//! The ids of sessions and full-size renders: 128 random bits from the
//! operating system, as 32 hexadecimal digits, so that no client can guess
//! another page's session or render.

/// Bytes in an id.
pub const ID_BYTES: usize = 16;

/// A new random id, or why the system gave no random bytes.
pub fn random_id() -> Result<String, getrandom::Error> {
    let mut bytes = [0u8; ID_BYTES];
    getrandom::fill(&mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Whether `text` has the shape of an id (checked before any lookup, so
/// that a request's text is never used as a file name).
pub fn is_id(text: &str) -> bool {
    text.len() == 2 * ID_BYTES && text.bytes().all(|b| b.is_ascii_hexdigit())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_128_random_bits() {
        let ids: Vec<String> = (0..64).map(|_| random_id().unwrap()).collect();
        assert!(ids.iter().all(|id| is_id(id)));
        let distinct: std::collections::HashSet<_> = ids.iter().collect();
        assert_eq!(distinct.len(), ids.len());
        // Every bit position takes both values over 64 ids (a counter or a
        // clock would leave the high bits fixed).
        for bit in 0..8 * ID_BYTES {
            let of = |id: &String| {
                let byte = u8::from_str_radix(&id[2 * (bit / 8)..2 * (bit / 8) + 2], 16).unwrap();
                byte >> (bit % 8) & 1
            };
            let ones = ids.iter().map(of).filter(|&b| b == 1).count();
            assert!(ones > 0 && ones < ids.len(), "bit {bit}: {ones} of 64");
        }
        assert!(!is_id("1"));
        assert!(!is_id("../../../../../../../../etc/passwd"));
    }
}
