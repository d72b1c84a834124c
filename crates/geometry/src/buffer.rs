//! Large arrays of plain values: a film's pixels, an accumulator's spread and passes, a BVH's leaves.
//!
//! A large array starts as zeroed memory that the system maps page by page where it is first written
//! or read: on Linux, an array of a mebibyte or more gets an anonymous mapping of its own, whatever the
//! allocator's state (glibc serves large requests from memory it already holds, after large frees,
//! and clears it by hand). Elsewhere, and where the mapping fails, the array is the allocator's zeroed
//! memory.
//!
//! A walk of a large BVH jumps between pages, and with 4 KiB pages most of its jumps miss the
//! translation buffers once its arrays exceed their reach. [`LargeBuffer::zeroed_on_huge_pages`]
//! puts such an array on 2 MiB pages where the system has transparent huge pages. A fresh huge page
//! is zeroed whole on its first write, and on a virtual machine whose host takes freed memory back
//! that can cost milliseconds per page: huge pages pay only where many queries read the array.

use bytemuck::Pod;
use std::ops::{Deref, DerefMut};

/// An array of `T` that starts zeroed (or as the values it is made from), read and written as a slice.
///
/// Hot loops take the slice once (`let values: &[T] = &buffer;`) and index that: each dereference
/// looks at where the values live.
///
/// ```
/// use raylume_geometry::LargeBuffer;
/// let mut counts = LargeBuffer::<u32>::zeroed(1 << 20);
/// counts[7] = 3;
/// let values: &[u32] = &counts;
/// assert_eq!((values.len(), values[7], values.iter().sum::<u32>()), (1 << 20, 3, 3));
/// ```
pub struct LargeBuffer<T: Pod> {
    storage: Storage<T>,
}

enum Storage<T> {
    Heap(Vec<T>),
    /// `len` values from byte `offset` of an anonymous mapping.
    #[cfg(target_os = "linux")]
    Mapped {
        map: memmap2::MmapMut,
        offset: usize,
        len: usize,
    },
}

/// The size of a huge page: the values of a mapping on huge pages start on such a boundary.
#[cfg(target_os = "linux")]
const HUGE_PAGE: usize = 2 << 20;

/// The smallest buffer, in bytes, that gets a mapping of its own.
#[cfg(target_os = "linux")]
const LEAST_MAPPED: usize = 1 << 20;

impl<T: Pod> LargeBuffer<T> {
    /// `len` zeroed values.
    pub fn zeroed(len: usize) -> Self {
        Self::zeroed_with(len, false)
    }

    /// `len` zeroed values, on huge pages where the system has them (Linux's transparent huge pages,
    /// for a buffer of a mebibyte or more): for an array that many queries read at random, such as a
    /// large BVH's leaves.
    ///
    /// ```
    /// use raylume_geometry::LargeBuffer;
    /// let leaves = LargeBuffer::<[f32; 16]>::zeroed_on_huge_pages(1 << 16);
    /// assert!(leaves.iter().all(|leaf| leaf.iter().all(|&x| x == 0.0)));
    /// ```
    pub fn zeroed_on_huge_pages(len: usize) -> Self {
        Self::zeroed_with(len, true)
    }

    fn zeroed_with(len: usize, huge: bool) -> Self {
        #[cfg(target_os = "linux")]
        if let Some(storage) = Self::mapped(len, huge) {
            return Self { storage };
        }
        let _ = huge;
        Self { storage: Storage::Heap(bytemuck::zeroed_vec(len)) }
    }

    /// A mapping of its own for `len` values, if the buffer is large enough and the system gives one;
    /// with `huge`, its values on a huge page boundary and the mapping marked for huge pages.
    #[cfg(target_os = "linux")]
    fn mapped(len: usize, huge: bool) -> Option<Storage<T>> {
        let bytes = len.checked_mul(size_of::<T>())?;
        if bytes < LEAST_MAPPED || align_of::<T>() > 4096 {
            return None;
        }
        // On huge pages, one huge page more than the values need, so that they can start on a boundary.
        let size = if huge { bytes.checked_next_multiple_of(HUGE_PAGE)?.checked_add(HUGE_PAGE)? } else { bytes };
        let map = memmap2::MmapOptions::new().len(size).map_anon().ok()?;
        let offset = if huge {
            let start = map.as_ptr() as usize;
            // Without transparent huge pages the advice fails, and the pages are ordinary ones.
            let _ = map.advise(memmap2::Advice::HugePage);
            start.next_multiple_of(HUGE_PAGE) - start
        } else {
            0
        };
        Some(Storage::Mapped { map, offset, len })
    }

    /// Whether the values live in a mapping of their own (on huge pages where the system has them).
    pub fn is_mapped(&self) -> bool {
        !matches!(self.storage, Storage::Heap(_))
    }
}

impl<T: Pod> From<Vec<T>> for LargeBuffer<T> {
    fn from(values: Vec<T>) -> Self {
        Self { storage: Storage::Heap(values) }
    }
}

impl<T: Pod> Deref for LargeBuffer<T> {
    type Target = [T];

    #[inline]
    fn deref(&self) -> &[T] {
        match &self.storage {
            Storage::Heap(values) => values,
            #[cfg(target_os = "linux")]
            Storage::Mapped { map, offset, len } => bytemuck::cast_slice(&map[*offset..*offset + len * size_of::<T>()]),
        }
    }
}

impl<T: Pod> DerefMut for LargeBuffer<T> {
    #[inline]
    fn deref_mut(&mut self) -> &mut [T] {
        match &mut self.storage {
            Storage::Heap(values) => values,
            #[cfg(target_os = "linux")]
            Storage::Mapped { map, offset, len } => {
                bytemuck::cast_slice_mut(&mut map[*offset..*offset + *len * size_of::<T>()])
            }
        }
    }
}

impl<T: Pod> Clone for LargeBuffer<T> {
    fn clone(&self) -> Self {
        Self::from(self.to_vec())
    }
}

impl<T: Pod + PartialEq> PartialEq for LargeBuffer<T> {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

impl<T: Pod + std::fmt::Debug> std::fmt::Debug for LargeBuffer<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        (**self).fmt(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_zeroed_buffer_is_zero_and_holds_what_is_written() {
        // Below, at and well above the size that gets a mapping of its own.
        for (len, huge) in [0, 1, 1000, (1 << 20) / 4 - 1, (1 << 20) / 4, 3 << 20, (5 << 20) + 17]
            .into_iter()
            .flat_map(|len| [(len, false), (len, true)])
        {
            let mut b =
                if huge { LargeBuffer::<u32>::zeroed_on_huge_pages(len) } else { LargeBuffer::<u32>::zeroed(len) };
            assert_eq!(b.len(), len);
            assert!(b.iter().all(|&v| v == 0), "{len} values not all zero");
            for (i, v) in b.iter_mut().enumerate() {
                *v = i as u32 ^ 0x5a5a_5a5a;
            }
            assert!(b.iter().enumerate().all(|(i, &v)| v == i as u32 ^ 0x5a5a_5a5a));
            let copy = b.clone();
            assert_eq!(copy, b);
            assert_eq!(copy.to_vec(), LargeBuffer::from(b.to_vec()).to_vec());
            if len > 0 {
                b[len - 1] ^= 1;
                assert_ne!(copy, b);
            }
        }
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn large_buffers_get_a_mapping_of_their_own_on_huge_pages_if_asked() {
        assert!(!LargeBuffer::<u32>::zeroed(1000).is_mapped());
        assert!(!LargeBuffer::<u32>::zeroed_on_huge_pages(1000).is_mapped());
        assert!(!LargeBuffer::<u32>::from(vec![0; 1 << 20]).is_mapped());
        let small_pages = LargeBuffer::<glam::Vec3>::zeroed(512 * 512);
        let huge_pages = LargeBuffer::<glam::Vec3>::zeroed_on_huge_pages(512 * 512);
        assert!(small_pages.is_mapped() && huge_pages.is_mapped());
        assert_eq!(huge_pages.as_ptr() as usize % HUGE_PAGE, 0);
        assert_eq!((small_pages.len(), huge_pages.len()), (512 * 512, 512 * 512));
    }
}
