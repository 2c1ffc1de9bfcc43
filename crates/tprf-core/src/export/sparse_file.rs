//! A writer that leaves holes: blocks of zero bytes are seeked over instead of written,
//! so a dense `.npy` cube in which light reached 1 % of the bins costs the disk (and the
//! write) about 1 % of its size. Readers see zeros in the holes (POSIX sparse files);
//! on a file system without holes the skipped blocks read as zeros all the same.

use std::io::{self, Seek, SeekFrom, Write};

/// Bytes per block, aligned on file offsets: a page, the unit file systems allocate.
pub const BLOCK: usize = 4096;

/// Wraps `inner` (positioned at offset 0 of an empty file). Bytes go through a one-block
/// buffer; a block that is all zero is not written. [`SparseWriter::finish`] writes the
/// last partial block and returns the logical length, which the caller sets as the
/// file's length (a trailing hole has no write to make it exist).
pub struct SparseWriter<W: Write + Seek> {
    inner: W,
    block: Vec<u8>,
    /// Offset of `block`'s first byte.
    block_at: u64,
    /// Where `inner` is positioned.
    inner_at: u64,
    /// Bytes not written (in skipped blocks).
    pub skipped_bytes: u64,
}

impl<W: Write + Seek> SparseWriter<W> {
    pub fn new(inner: W) -> SparseWriter<W> {
        SparseWriter {
            inner,
            block: Vec::with_capacity(BLOCK),
            block_at: 0,
            inner_at: 0,
            skipped_bytes: 0,
        }
    }

    /// Write the buffered block (skipped if all zero) and start the next one.
    fn flush_block(&mut self) -> io::Result<()> {
        if self.block.is_empty() {
            return Ok(());
        }
        if is_zero(&self.block) {
            self.skipped_bytes += self.block.len() as u64;
        } else {
            if self.inner_at != self.block_at {
                self.inner.seek(SeekFrom::Start(self.block_at))?;
            }
            self.inner.write_all(&self.block)?;
            self.inner_at = self.block_at + self.block.len() as u64;
        }
        self.block_at += self.block.len() as u64;
        self.block.clear();
        Ok(())
    }

    /// Write what is buffered; the logical length of the file (bytes given), and the
    /// writer. A trailing zero block is never written: the caller extends the file to
    /// the length (`File::set_len`).
    pub fn finish(mut self) -> io::Result<(u64, W)> {
        self.flush_block()?;
        self.inner.flush()?;
        Ok((self.block_at, self.inner))
    }
}

impl<W: Write + Seek> Write for SparseWriter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let room = BLOCK - self.block.len();
        let n = buf.len().min(room);
        self.block.extend_from_slice(&buf[..n]);
        if self.block.len() == BLOCK {
            self.flush_block()?;
        }
        Ok(n)
    }

    /// Buffered bytes stay buffered (a block is only judged whole); `inner` is flushed.
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// Whether every byte of `b` is zero (eight at a time).
fn is_zero(b: &[u8]) -> bool {
    let (chunks, rest) = b.split_at(b.len() / 8 * 8);
    chunks
        .chunks_exact(8)
        .all(|c| u64::from_ne_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]) == 0)
        && rest.iter().all(|&x| x == 0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    /// A file stand-in that records every write's offset and length.
    struct Recorder {
        file: Cursor<Vec<u8>>,
        writes: Vec<(u64, usize)>,
    }

    impl Write for Recorder {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            self.writes.push((self.file.position(), buf.len()));
            self.file.write(buf)
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    impl Seek for Recorder {
        fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
            self.file.seek(to)
        }
    }

    /// Bytes with non-zero values at a few hand-chosen places, written in uneven
    /// pieces: the file holds the same bytes once the holes read as zero, and only the
    /// blocks holding a non-zero byte were written.
    #[test]
    fn zero_blocks_are_holes_and_the_bytes_are_kept() {
        let len = 10 * BLOCK + 123;
        let mut data = vec![0u8; len];
        // Non-zero bytes in blocks 0, 3 (its last byte), 4 (first byte) and the tail.
        for &i in &[5, 4 * BLOCK - 1, 4 * BLOCK, 10 * BLOCK + 100] {
            data[i] = 7;
        }
        let mut w = SparseWriter::new(Recorder {
            file: Cursor::new(Vec::new()),
            writes: Vec::new(),
        });
        let mut at = 0;
        for piece in [1, 4000, 9000, 3, 20000].iter().cycle() {
            if at >= len {
                break;
            }
            let end = (at + piece).min(len);
            w.write_all(&data[at..end]).unwrap();
            at = end;
        }
        let skipped = w.skipped_bytes;
        let (logical, rec) = w.finish().unwrap();
        assert_eq!(logical, len as u64);
        let mut file = rec.file.into_inner();
        // The file is extended to its length, as the caller does with set_len.
        file.resize(len, 0);
        assert_eq!(file, data);
        let blocks: Vec<u64> = rec.writes.iter().map(|w| w.0 / BLOCK as u64).collect();
        assert_eq!(blocks, vec![0, 3, 4, 10]);
        assert_eq!(skipped, (len - 3 * BLOCK - 123) as u64);
    }

    /// All zero: nothing written at all; a length of zero bytes: nothing either.
    #[test]
    fn all_zero_writes_nothing() {
        let mut w = SparseWriter::new(Recorder {
            file: Cursor::new(Vec::new()),
            writes: Vec::new(),
        });
        w.write_all(&vec![0u8; 3 * BLOCK + 1]).unwrap();
        let (logical, rec) = w.finish().unwrap();
        assert_eq!(logical, (3 * BLOCK + 1) as u64);
        assert!(rec.writes.is_empty());
        let (logical, _) = SparseWriter::new(Cursor::new(Vec::<u8>::new()))
            .finish()
            .unwrap();
        assert_eq!(logical, 0);
    }
}
