//! Caller-owned storage: the storage-struct machinery shared by every controller's file (magic
//! word, typed access, pointer checks, parameter-error reporting) and [`init`], the body of every
//! `*_init` function.

use core::ffi::c_char;
use core::ptr::{self, addr_of, addr_of_mut};

use super::{FlcParamError, FlcResult};
use crate::params::ParamError;

/// Ties a storage struct to the Rust type it holds.
pub(super) trait Storage {
    type Inner;
    const MAGIC: u64;
}

macro_rules! storage {
    ($storage:ty, $inner:ty, $magic:expr) => {
        impl $crate::capi::storage::Storage for $storage {
            type Inner = $inner;
            const MAGIC: u64 = $magic;
        }
        const _: () = {
            assert!(core::mem::size_of::<$inner>() <= core::mem::size_of::<$storage>() - 8, "storage struct too small: raise its *_WORDS");
            assert!(core::mem::align_of::<$inner>() <= core::mem::align_of::<$storage>(), "storage struct under-aligned");
        };
    };
}
pub(super) use storage;

macro_rules! tri {
    ($e:expr) => {
        match $e {
            Ok(v) => v,
            Err(e) => return e,
        }
    };
}
pub(super) use tri;

/// The initialised controller in `s`, or why there is none.
///
/// # Safety
/// `s` is NULL or points to memory valid for reads and writes of `S` (any contents).
pub(super) unsafe fn get_mut<'a, S: Storage>(s: *mut S) -> Result<&'a mut S::Inner, FlcResult> {
    check_ptr(s.cast_const())?;
    // SAFETY: `s` is non-null and aligned (checked) and valid for reads (caller contract); the
    // magic word is a plain u64, any bit pattern is valid.
    let magic = unsafe { ptr::read(addr_of!((*s.cast::<Layout>()).magic)) };
    if magic != S::MAGIC {
        return Err(FlcResult::NotInitialized);
    }
    // SAFETY: the magic word is only written by `*_init` after a valid `S::Inner` has been written
    // to the storage, which is aligned for it (const-asserted above) and big enough.
    Ok(unsafe { &mut *storage_ptr(s) })
}

/// As [`get_mut`], shared.
///
/// # Safety
/// `s` is NULL or points to memory valid for reads of `S` (any contents).
pub(super) unsafe fn get_ref<'a, S: Storage>(s: *const S) -> Result<&'a S::Inner, FlcResult> {
    check_ptr(s)?;
    // SAFETY: as in `get_mut`.
    let magic = unsafe { ptr::read(addr_of!((*s.cast::<Layout>()).magic)) };
    if magic != S::MAGIC {
        return Err(FlcResult::NotInitialized);
    }
    // SAFETY: as in `get_mut`.
    Ok(unsafe { &*storage_ptr(s.cast_mut()).cast_const() })
}

/// The common layout of every storage struct: the magic word, then the storage words.
#[repr(C)]
struct Layout {
    magic: u64,
    storage: [u64; 0],
}

/// Pointer to the storage words of `s`, typed as the controller.
///
/// # Safety
/// `s` is non-null, aligned and points to an `S`.
pub(super) unsafe fn storage_ptr<S: Storage>(s: *mut S) -> *mut S::Inner {
    // SAFETY: every storage struct is `#[repr(C)] { u64, [u64; N] }`, so the storage words start
    // right after the magic word, as in `Layout`.
    unsafe { addr_of_mut!((*s.cast::<Layout>()).storage).cast::<S::Inner>() }
}

/// NULL and alignment check of a pointer argument.
pub(super) fn check_ptr<T>(p: *const T) -> Result<(), FlcResult> {
    if p.is_null() {
        Err(FlcResult::NullPointer)
    } else if !p.is_aligned() {
        Err(FlcResult::Misaligned)
    } else {
        Ok(())
    }
}

/// Reads a caller's input struct.
///
/// # Safety
/// `p` is NULL or points to a valid `T`.
pub(super) unsafe fn read_in<T: Copy>(p: *const T) -> Result<T, FlcResult> {
    check_ptr(p)?;
    // SAFETY: non-null and aligned (checked), valid (caller contract).
    Ok(unsafe { ptr::read(p) })
}

/// Writes an output for the caller.
///
/// # Safety
/// `p` is non-null, aligned and valid for writes of `T` (checked by the caller of this function).
pub(super) unsafe fn write_out<T>(p: *mut T, value: T) {
    // SAFETY: caller contract.
    unsafe { ptr::write(p, value) }
}

/// Stores `e` in `*out` when `out` is non-null and aligned (truncated, NUL-terminated).
///
/// # Safety
/// `out` is NULL or valid for writes of `FlcParamError`.
pub(super) unsafe fn report(out: *mut FlcParamError, e: ParamError) -> FlcResult {
    if check_ptr(out.cast_const()).is_ok() {
        let mut r = FlcParamError { field: [0; 32], problem: [0; 64] };
        copy_c_str(&mut r.field, e.field);
        copy_c_str(&mut r.problem, e.problem);
        // SAFETY: checked non-null and aligned; valid for writes (caller contract).
        unsafe { write_out(out, r) };
    }
    FlcResult::InvalidParams
}

pub(super) fn copy_c_str(dst: &mut [c_char], src: &str) {
    let n = dst.len().saturating_sub(1);
    for (d, &b) in dst.iter_mut().zip(src.as_bytes().iter().take(n)) {
        *d = b as c_char;
    }
}

pub(super) const fn param_error(field: &'static str, problem: &'static str) -> ParamError {
    ParamError { field, problem }
}

/// The body of every `*_init` function: checks `s`, reads `*params`, `build`s the controller's
/// state from them (validation included) and, on success, `write`s it into the storage and marks
/// the storage initialised. On `FLC_RESULT_INVALID_PARAMS`, `*error` (may be NULL) names the field
/// and `*s` is unchanged.
///
/// `write` gets a non-null pointer, aligned and valid for writes of `S::Inner` (the storage words)
/// and must leave a fully initialised `S::Inner` there: `ptr::write` for a controller built by
/// value, an in-place initialiser for the detector.
///
/// # Safety
/// Each pointer is NULL or valid for reads (`params`) / writes (`s`, `error`) of its type.
pub(super) unsafe fn init<S: Storage, P: Copy, B>(
    s: *mut S,
    params: *const P,
    error: *mut FlcParamError,
    build: impl FnOnce(P) -> Result<B, ParamError>,
    write: unsafe fn(*mut S::Inner, B),
) -> FlcResult {
    tri!(check_ptr(s.cast_const()));
    // SAFETY: caller contract.
    let p = tri!(unsafe { read_in(params) });
    match build(p) {
        Ok(b) => {
            // SAFETY: `s` is non-null and aligned (checked) and valid for writes (caller contract);
            // the storage is big enough and aligned for `S::Inner` (const-asserted). `write`
            // initialises it before the magic word marks it initialised.
            unsafe {
                write(storage_ptr(s), b);
                ptr::write(addr_of_mut!((*s.cast::<Layout>()).magic), S::MAGIC);
            }
            FlcResult::Ok
        }
        // SAFETY: caller contract.
        Err(e) => unsafe { report(error, e) },
    }
}
