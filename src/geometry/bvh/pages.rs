//! The BVH's large arrays (nodes and leaf packets) in memory of their own, advised for
//! transparent huge pages, as Embree allocates its BVH.
//!
//! A ray reads a few nodes and packets at random places of arrays of tens of megabytes on the
//! 1M-triangle meshes. On 4 KiB pages nearly every such read also misses the TLB (a core's
//! second-level TLB covers 12 MiB or less); on 2 MiB pages the whole tree is covered. Measured
//! on grid1m (docs/performance.md §1, "Huge pages"): the same tree traced 1.12× as fast with
//! the system's transparent huge pages set to `always`, which is what this module gives under
//! the usual `madvise` setting without touching anything else of the process. (The allocator's
//! own huge pages stay off: §4 found them costly for renders.)
//!
//! Arrays smaller than one huge page stay in a `Vec`. On other systems than Linux, when the
//! mapping fails, or when the system's transparent huge pages are `never`, the array is in
//! ordinary memory: the contents and every result are the same either way.

use std::ops::Deref;

/// Size and alignment of a huge page (x86-64 and most Linux systems).
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
const HUGE_PAGE: usize = 2 << 20;

/// An immutable array, in a mapping of its own advised for huge pages when it fills at least
/// one ([`HUGE_PAGE`]), in a `Vec` otherwise. Reading it costs what reading a `Vec` does (one
/// pointer and one length, whichever memory holds it).
pub(super) struct PagedArray<T: Copy> {
    /// `len` initialised elements, owned by `owner`.
    ptr: std::ptr::NonNull<T>,
    len: usize,
    owner: Owner<T>,
}

enum Owner<T> {
    Vec(#[allow(dead_code)] Vec<T>),
    /// A mapping of this many bytes at `ptr`, aligned to a huge page; unmapped on drop.
    #[cfg(target_os = "linux")]
    Mapped(usize),
}

// SAFETY: the array owns its memory as a `Vec` owns its buffer and is written only through
// `as_mut_slice` (`&mut self`), so it can be sent and shared as a `Vec<T>` can.
unsafe impl<T: Copy + Send> Send for PagedArray<T> {}
// SAFETY: as above (only shared reads).
unsafe impl<T: Copy + Sync> Sync for PagedArray<T> {}

impl<T: Copy> PagedArray<T> {
    /// `v`'s elements, moved into huge-page memory when `v` fills at least one huge page.
    pub fn new(v: Vec<T>) -> PagedArray<T> {
        #[cfg(target_os = "linux")]
        if std::mem::size_of_val(&v[..]) >= HUGE_PAGE
            && let Some(a) = Self::map(v.len(), |dst| {
                // SAFETY: `dst` holds room for `v.len()` elements and does not overlap `v`.
                unsafe { std::ptr::copy_nonoverlapping(v.as_ptr(), dst, v.len()) }
            })
        {
            return a;
        }
        Self::from_vec(v)
    }

    /// `len` copies of `value`, to be filled in place ([`Self::as_mut_slice`]) before the array
    /// is shared: a large array is written straight into its huge pages, without the copy (and
    /// twice the memory) of [`Self::new`].
    pub fn filled(len: usize, value: T) -> PagedArray<T> {
        #[cfg(target_os = "linux")]
        if len.saturating_mul(std::mem::size_of::<T>()) >= HUGE_PAGE
            && let Some(a) = Self::map(len, |dst| {
                for i in 0..len {
                    // SAFETY: `dst` holds room for `len` elements.
                    unsafe { dst.add(i).write(value) };
                }
            })
        {
            return a;
        }
        Self::from_vec(vec![value; len])
    }

    /// The elements, to write in place (only the owner can: the array is not shared yet).
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        // SAFETY: `len` initialised elements at `ptr`, owned by `self`, borrowed mutably once.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }

    fn from_vec(mut v: Vec<T>) -> PagedArray<T> {
        PagedArray {
            // a `Vec`'s pointer is never null (dangling when empty); moving the `Vec` into
            // `owner` does not move its buffer
            ptr: std::ptr::NonNull::new(v.as_mut_ptr()).unwrap_or(std::ptr::NonNull::dangling()),
            len: v.len(),
            owner: Owner::Vec(v),
        }
    }

    /// Whether the array is in a mapping advised for huge pages (not whether the kernel gave
    /// them: `AnonHugePages` in `/proc/self/smaps` says that).
    #[cfg(test)]
    pub fn is_mapped(&self) -> bool {
        !matches!(self.owner, Owner::Vec(_))
    }

    /// A fresh anonymous mapping for `len` elements that starts on a huge-page boundary and is
    /// advised for huge pages before its first touch (advice on memory already touched would
    /// only take effect when the kernel's background thread merges the pages, if ever), its
    /// elements written by `init` (which must write all `len`).
    #[cfg(target_os = "linux")]
    fn map(len: usize, init: impl FnOnce(*mut T)) -> Option<PagedArray<T>> {
        // whole huge pages, so that the array's tail is on one too (at most 2 MiB of memory
        // more, for arrays of 2 MiB and more)
        let bytes = len
            .checked_mul(std::mem::size_of::<T>())?
            .checked_next_multiple_of(HUGE_PAGE)?;
        let reserve = bytes.checked_add(HUGE_PAGE)?;
        // SAFETY: an anonymous private mapping, no address hint; checked for failure.
        let base = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                reserve,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        if base == libc::MAP_FAILED {
            return None;
        }
        let base = base as usize;
        let start = base.next_multiple_of(HUGE_PAGE);
        let (head, tail) = (start - base, base + reserve - (start + bytes));
        // SAFETY: both ranges lie in the mapping just made and outside [start, start + bytes),
        // and are whole pages (base is a page multiple, start and bytes huge-page multiples).
        // The advice only concerns that range. Failure of either leaves ordinary memory, which
        // is fine.
        unsafe {
            if head > 0 {
                libc::munmap(base as *mut libc::c_void, head);
            }
            if tail > 0 {
                libc::munmap((start + bytes) as *mut libc::c_void, tail);
            }
            libc::madvise(start as *mut libc::c_void, bytes, libc::MADV_HUGEPAGE);
        }
        // The mapping holds `bytes` writable bytes, room for `len` elements, aligned to 2 MiB
        // (more than `T` needs).
        let ptr = std::ptr::NonNull::new(start as *mut T)?;
        init(ptr.as_ptr());
        Some(PagedArray {
            ptr,
            len,
            owner: Owner::Mapped(bytes),
        })
    }
}

impl<T: Copy> Deref for PagedArray<T> {
    type Target = [T];

    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: `len` initialised elements at `ptr`, owned by `self.owner`, alive as long as
        // `self`, written only through `as_mut_slice`, which cannot overlap this borrow.
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> Drop for PagedArray<T> {
    fn drop(&mut self) {
        #[cfg(target_os = "linux")]
        if let Owner::Mapped(bytes) = self.owner {
            // SAFETY: the mapping made in `map`, unmapped once (`T: Copy` needs no drop).
            unsafe { libc::munmap(self.ptr.as_ptr() as *mut libc::c_void, bytes) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A large array is copied whole into a huge-page-aligned mapping, a small one stays in its
    /// `Vec`; both read back what was put in, and dropping unmaps without a fault.
    #[test]
    fn contents_alignment_and_storage() {
        // 3 MiB and a bit of u64s: one huge page and a partial one
        let n = (3 << 20) / 8 + 12_345;
        let v: Vec<u64> = (0..n as u64)
            .map(|i| i.wrapping_mul(0x9E37_79B9_7F4A_7C15))
            .collect();
        let a = PagedArray::new(v.clone());
        assert_eq!(&a[..], &v[..]);
        #[cfg(target_os = "linux")]
        {
            assert!(a.is_mapped());
            assert_eq!(a.as_ptr() as usize % HUGE_PAGE, 0);
        }
        drop(a);
        let small: Vec<u64> = (0..1000).collect();
        let b = PagedArray::new(small.clone());
        assert!(!b.is_mapped());
        assert_eq!(&b[..], &small[..]);
        let empty = PagedArray::<u64>::new(Vec::new());
        assert!(empty.is_empty() && !empty.is_mapped());
    }

    /// An array filled in place holds the value it was made with, then what was written; a
    /// large one is mapped, a small one (and an empty one) is a `Vec`, written alike.
    #[test]
    fn filled_in_place() {
        for (n, mapped) in [((5 << 20) / 4 + 7, true), (1000, false), (0, false)] {
            let mut a = PagedArray::filled(n, 7u32);
            assert_eq!(a.len(), n);
            assert!(a.iter().all(|&x| x == 7));
            for (i, x) in a.as_mut_slice().iter_mut().enumerate().step_by(3) {
                *x = i as u32;
            }
            assert!(
                a.iter()
                    .enumerate()
                    .all(|(i, &x)| x == if i % 3 == 0 { i as u32 } else { 7 })
            );
            assert_eq!(a.is_mapped(), mapped && cfg!(target_os = "linux"), "{n}");
        }
    }
}
