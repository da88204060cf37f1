//! SHA-256 of the input files a report names, so that a laboratory can tell later which
//! recording and configuration a calibration came from: the well-kept pure-Rust `sha2` crate (no
//! system library), in place of the hand-written implementation this module held before.

use sha2::{Digest, Sha256};
use std::io::Read as _;
use std::path::Path;

/// The digest as lower-case hex.
fn hex(h: Sha256) -> String {
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// The SHA-256 of `data` (hex).
pub fn of_bytes(data: &[u8]) -> String {
    let mut h = Sha256::new();
    h.update(data);
    hex(h)
}

/// The SHA-256 (hex) and the size (bytes) of a file, read in blocks.
pub fn of_file(path: &Path) -> Result<(String, u64), crate::Error> {
    let err = |e: std::io::Error| {
        format!(
            "{}: cannot read it to take its SHA-256: {e}",
            path.display()
        )
    };
    let mut file = std::fs::File::open(path).map_err(err)?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut size = 0u64;
    loop {
        let n = file.read(&mut buf).map_err(err)?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
        size += n as u64;
    }
    Ok((hex(h), size))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The test vectors of FIPS 180-4's examples (NIST CSRC, "SHA-256" example values).
    #[test]
    fn standard_test_vectors() {
        assert_eq!(
            of_bytes(b""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
        assert_eq!(
            of_bytes(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(
            of_bytes(b"abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1"
        );
        // One million 'a', fed in uneven pieces: blocks split across updates.
        let mut h = Sha256::new();
        let chunk = [b'a'; 997];
        let mut left = 1_000_000usize;
        while left > 0 {
            let n = left.min(chunk.len());
            h.update(&chunk[..n]);
            left -= n;
        }
        assert_eq!(
            hex(h),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0"
        );
    }

    #[test]
    fn padding_at_every_length_near_a_block() {
        // 55 bytes fit the length in the last block; 56 to 63 need another block.
        let digests: Vec<String> = (54..=65).map(|n| of_bytes(&vec![b'x'; n])).collect();
        for (i, a) in digests.iter().enumerate() {
            assert_eq!(a.len(), 64);
            assert!(digests[i + 1..].iter().all(|b| b != a));
        }
        let mut h = Sha256::new();
        h.update([b'x'; 30]);
        h.update([b'x'; 26]);
        assert_eq!(hex(h), of_bytes(&[b'x'; 56]));
    }
}
