//! A float32 `.npy` array read a range at a time: the header parsed once, then
//! positioned reads of any run of elements. What reads a cube larger than memory, or
//! one row of it, goes through here; nothing the size of the file is held.

use super::ExportError;
use crate::budget;
use std::fs::File;
use std::io::{Cursor, Read};
use std::path::{Path, PathBuf};

/// The largest header read: numpy writes a few hundred bytes; a forged length beyond
/// this is refused instead of allocated.
const MAX_HEADER_BYTES: u64 = 1 << 20;

/// Elements read per positioned read.
const READ_CHUNK: usize = 1 << 18;

/// An open float32 C-order `.npy` array (`<f4` or `>f4`).
pub struct NpyF32 {
    file: File,
    path: PathBuf,
    shape: Vec<u64>,
    /// Bytes before the first element.
    data_offset: u64,
    big_endian: bool,
}

impl NpyF32 {
    /// Open `path` (a regular file, [`budget::open_regular`]) and check its header: C
    /// order, float32, and the bytes its shape needs present after the header.
    pub fn open(path: &Path) -> Result<NpyF32, ExportError> {
        let path_buf = || path.to_path_buf();
        let (mut file, file_len) = budget::open_regular(path)?;
        let mut prefix = Vec::new();
        (&mut file)
            .take(file_len.min(MAX_HEADER_BYTES))
            .read_to_end(&mut prefix)
            .map_err(|source| ExportError::Read {
                path: path_buf(),
                source,
            })?;
        let mut cursor = Cursor::new(&prefix[..]);
        let header =
            npyz::NpyHeader::from_reader(&mut cursor).map_err(|source| ExportError::NotNpy {
                path: path_buf(),
                source,
            })?;
        let data_offset = cursor.position();
        if header.order() != npyz::Order::C {
            return Err(ExportError::FortranOrder { path: path_buf() });
        }
        let dtype = header.dtype();
        let big_endian = match &dtype {
            npyz::DType::Plain(t) if t.to_string() == "<f4" => false,
            npyz::DType::Plain(t) if t.to_string() == ">f4" => true,
            other => {
                return Err(ExportError::NotF32 {
                    path: path_buf(),
                    source: std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        format!("its dtype is {}", other.descr()),
                    ),
                });
            }
        };
        let shape = header.shape().to_vec();
        let need_bytes = super::npy_f32_bytes(&shape);
        let have_bytes = file_len.saturating_sub(data_offset);
        if need_bytes > have_bytes {
            return Err(ExportError::Truncated {
                path: path_buf(),
                shape,
                need_bytes,
                have_bytes,
            });
        }
        Ok(NpyF32 {
            file,
            path: path_buf(),
            shape,
            data_offset,
            big_endian,
        })
    }

    /// The array's shape, as in its header.
    pub fn shape(&self) -> &[u64] {
        &self.shape
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Elements in the array (the product of its shape; the header check made it fit
    /// the file).
    pub fn len(&self) -> u64 {
        self.shape.iter().product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Read `out.len()` elements starting at element `first` (C order).
    pub fn read(&self, first: u64, out: &mut [f32]) -> Result<(), ExportError> {
        let end = first.checked_add(out.len() as u64);
        if end.is_none_or(|e| e > self.len()) {
            return Err(ExportError::Read {
                path: self.path.clone(),
                source: std::io::Error::new(
                    std::io::ErrorKind::UnexpectedEof,
                    format!(
                        "elements {first}..+{} are past the array's {}",
                        out.len(),
                        self.len()
                    ),
                ),
            });
        }
        let mut bytes = vec![0u8; 4 * READ_CHUNK.min(out.len())];
        let mut at = self.data_offset + 4 * first;
        for chunk in out.chunks_mut(READ_CHUNK) {
            let b = &mut bytes[..4 * chunk.len()];
            read_exact_at(&self.file, b, at).map_err(|source| ExportError::Read {
                path: self.path.clone(),
                source,
            })?;
            for (v, q) in chunk.iter_mut().zip(b.chunks_exact(4)) {
                let q = [q[0], q[1], q[2], q[3]];
                *v = if self.big_endian {
                    f32::from_be_bytes(q)
                } else {
                    f32::from_le_bytes(q)
                };
            }
            at += b.len() as u64;
        }
        Ok(())
    }

    /// The whole array, after checking that it fits in memory.
    pub fn read_all(&self) -> Result<Vec<f32>, ExportError> {
        let n = self.len();
        budget::check(
            n.saturating_mul(4),
            "the .npy array",
            format_args!("reading {}", self.path.display()),
        )?;
        let mut data = vec![0.0f32; n as usize];
        self.read(0, &mut data)?;
        Ok(data)
    }
}

#[cfg(unix)]
fn read_exact_at(file: &File, buf: &mut [u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, buf, offset)
}

#[cfg(windows)]
fn read_exact_at(file: &File, mut buf: &mut [u8], mut offset: u64) -> std::io::Result<()> {
    use std::os::windows::fs::FileExt;
    while !buf.is_empty() {
        match file.seek_read(buf, offset)? {
            0 => return Err(std::io::ErrorKind::UnexpectedEof.into()),
            n => {
                buf = &mut buf[n..];
                offset += n as u64;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("tprf-npy-read-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    #[test]
    fn ranges_read_back_what_numpy_layout_holds() {
        let path = temp("ranges.npy");
        let data: Vec<f32> = (0..2 * 3 * 5).map(|i| i as f32 * 0.5 - 3.0).collect();
        super::super::write_npy_f32(&path, &[2, 3, 5], &data).unwrap();
        let npy = NpyF32::open(&path).unwrap();
        assert_eq!(npy.shape(), &[2, 3, 5]);
        let mut part = [0.0f32; 7];
        npy.read(11, &mut part).unwrap();
        assert_eq!(&part[..], &data[11..18]);
        assert_eq!(npy.read_all().unwrap(), data);
        let mut past = [0.0f32; 2];
        assert!(npy.read(29, &mut past).is_err());
    }

    #[test]
    fn big_endian_float32_is_read() {
        // A numpy '>f4' array written by hand: header padded to 64 bytes as numpy does.
        let path = temp("be.npy");
        let dict = "{'descr': '>f4', 'fortran_order': False, 'shape': (3,), }";
        let mut header = dict.to_string();
        while !(10 + header.len() + 1).is_multiple_of(64) {
            header.push(' ');
        }
        header.push('\n');
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        bytes.extend((header.len() as u16).to_le_bytes());
        bytes.extend(header.as_bytes());
        for v in [1.5f32, -2.0, 1e-3] {
            bytes.extend(v.to_be_bytes());
        }
        std::fs::write(&path, bytes).unwrap();
        let npy = NpyF32::open(&path).unwrap();
        assert_eq!(npy.read_all().unwrap(), vec![1.5, -2.0, 1e-3]);
    }

    #[test]
    fn a_short_file_and_a_wrong_dtype_are_refused() {
        let path = temp("short.npy");
        super::super::write_npy_f32(&path, &[4, 4], &[1.0; 16]).unwrap();
        let len = std::fs::metadata(&path).unwrap().len();
        let f = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
        f.set_len(len - 4).unwrap();
        let err = NpyF32::open(&path).err().unwrap().to_string();
        assert!(err.contains("needs 64 bytes"), "{err}");

        use npyz::WriterBuilder;
        let path = temp("f8.npy");
        let mut w = npyz::WriteOptions::<f64>::new()
            .default_dtype()
            .shape(&[2])
            .writer(std::fs::File::create(&path).unwrap())
            .begin_nd()
            .unwrap();
        w.extend([1.0f64, 2.0]).unwrap();
        w.finish().unwrap();
        let err = NpyF32::open(&path).err().unwrap();
        assert!(matches!(err, ExportError::NotF32 { .. }), "{err}");
    }
}
