//! Voxels in their file's own type: [`Voxels`] holds one [`Buf`] of `u8`, `i8`, `u16`, `i16` or `f32`
//! values, x fastest, so a 512²×1000 u16 CT takes 512 MiB, not the 1 GiB of an `f32` copy. Files of
//! the other types (`u32`, `i32`, `f64`) are converted to `f32` once, while they are read, and the
//! [`Volume`](super::Volume) says so (`converted_from`).
//!
//! Code that reads voxels dispatches on the type **once** (per raycast, per brick, per row), then runs
//! monomorphised over `&[T]` with `T: Voxel`: either with the [`with_voxels!`](crate::with_voxels)
//! macro, whose body is compiled once per type, or with a [`VoxelVisitor`] (a generic method; use it
//! where a named type is clearer than a macro body).

use super::ScalarType;
use std::ops::{Deref, DerefMut};

mod sealed {
    pub trait Sealed {}
    impl Sealed for u8 {}
    impl Sealed for i8 {}
    impl Sealed for u16 {}
    impl Sealed for i16 {}
    impl Sealed for f32 {}
}

/// A voxel type kept as stored: `u8`, `i8`, `u16`, `i16` or `f32` (sealed: no other type can be a
/// [`Voxels`] variant).
pub trait Voxel:
    Copy + Send + Sync + PartialEq + PartialOrd + Default + std::fmt::Debug + bytemuck::Pod + sealed::Sealed + 'static
{
    /// The type as files name it.
    const TYPE: ScalarType;
    /// The value in the file's units (exact for every type but `f32`, which is itself).
    fn to_f32(self) -> f32;
    /// The value with its bytes reversed (for files of the other byte order).
    fn swap_bytes(self) -> Self;
    /// False for `f32` NaN and infinities; integers are always finite.
    fn is_finite(self) -> bool;
}

macro_rules! int_voxel {
    ($t:ty, $st:ident) => {
        impl Voxel for $t {
            const TYPE: ScalarType = ScalarType::$st;
            #[inline(always)]
            fn to_f32(self) -> f32 {
                f32::from(self)
            }
            #[inline(always)]
            fn swap_bytes(self) -> Self {
                <$t>::swap_bytes(self)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                true
            }
        }
    };
}
int_voxel!(u8, U8);
int_voxel!(i8, I8);
int_voxel!(u16, U16);
int_voxel!(i16, I16);

impl Voxel for f32 {
    const TYPE: ScalarType = ScalarType::F32;
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn swap_bytes(self) -> Self {
        f32::from_bits(self.to_bits().swap_bytes())
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
}

/// The voxel buffer of one type: derefs to `[T]`. Owned; it is allocated once at the size the volume's
/// header requires and filled in place by the readers (a zeroed allocation, so pages that a failed read
/// never reached are never touched).
#[derive(Clone, PartialEq)]
pub struct Buf<T: Voxel> {
    data: Vec<T>,
}

impl<T: Voxel> Buf<T> {
    /// `len` zero voxels.
    pub(crate) fn zeroed(len: usize) -> Buf<T> {
        Buf { data: vec![T::default(); len] }
    }

    /// The voxels as bytes (in memory order), to read a file's data straight into.
    pub(crate) fn bytes_mut(&mut self) -> &mut [u8] {
        bytemuck::cast_slice_mut(&mut self.data)
    }
}

impl<T: Voxel> From<Vec<T>> for Buf<T> {
    fn from(data: Vec<T>) -> Buf<T> {
        Buf { data }
    }
}

impl<T: Voxel> Deref for Buf<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        &self.data
    }
}

impl<T: Voxel> DerefMut for Buf<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.data
    }
}

impl<T: Voxel> std::fmt::Debug for Buf<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Buf<{:?}>[{} voxels]", T::TYPE, self.data.len())
    }
}

/// A volume's voxels in their stored type.
#[derive(Clone, Debug, PartialEq)]
pub enum Voxels {
    /// Unsigned 8-bit values, as stored in the file.
    U8(Buf<u8>),
    /// Signed 8-bit values, as stored in the file.
    I8(Buf<i8>),
    /// Unsigned 16-bit values, as stored in the file.
    U16(Buf<u16>),
    /// Signed 16-bit values, as stored in the file.
    I16(Buf<i16>),
    /// 32-bit floats: stored so in the file, or converted from u32, i32 or f64.
    F32(Buf<f32>),
}

/// Run `$body` with `$data` bound to the voxels as `&Buf<T>` (deref: `&[T]`), compiled once per voxel
/// type: the one-time dispatch. [`Voxel`] is in scope in the body (`$data[i].to_f32()`).
///
/// ```ignore
/// let sum: f64 = with_voxels!(&volume.voxels, v => v.iter().map(|x| f64::from(x.to_f32())).sum());
/// ```
#[macro_export]
macro_rules! with_voxels {
    ($voxels:expr, $data:ident => $body:expr) => {{
        #[allow(unused_imports)]
        use $crate::volume::Voxel as _;
        match $voxels {
            $crate::volume::Voxels::U8($data) => $body,
            $crate::volume::Voxels::I8($data) => $body,
            $crate::volume::Voxels::U16($data) => $body,
            $crate::volume::Voxels::I16($data) => $body,
            $crate::volume::Voxels::F32($data) => $body,
        }
    }};
}

/// A computation over the voxels of any type: [`Voxels::visit`] calls `visit` once with the typed slice.
pub trait VoxelVisitor {
    /// The result of the computation.
    type Output;
    /// Run the computation on the voxels as one typed slice, x fastest, then y, then z.
    fn visit<T: Voxel>(self, data: &[T]) -> Self::Output;
}

impl Voxels {
    /// Call `visitor` once with the typed voxels.
    pub fn visit<V: VoxelVisitor>(&self, visitor: V) -> V::Output {
        with_voxels!(self, d => visitor.visit(&d[..]))
    }

    /// The stored type.
    pub fn scalar_type(&self) -> ScalarType {
        with_voxels!(self, d => element_type(&d[..]))
    }

    /// Number of voxels.
    pub fn len(&self) -> usize {
        with_voxels!(self, d => d.len())
    }

    /// True when there are no voxels (a [`Volume`](super::Volume) always has some).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bytes the voxels take in memory.
    pub fn bytes(&self) -> usize {
        self.len() * self.scalar_type().size()
    }

    /// Voxel `i` in the file's units. One dispatch per call: for a few values (tests, probes); loops
    /// dispatch once with [`with_voxels!`](crate::with_voxels).
    #[inline]
    pub fn get(&self, i: usize) -> f32 {
        with_voxels!(self, d => d[i].to_f32())
    }

    /// Every voxel as `f32`: a full copy, for tests and small volumes.
    pub fn to_f32_vec(&self) -> Vec<f32> {
        with_voxels!(self, d => d.iter().map(|v| v.to_f32()).collect())
    }
}

fn element_type<T: Voxel>(_: &[T]) -> ScalarType {
    T::TYPE
}

macro_rules! from_vec {
    ($t:ty, $v:ident) => {
        impl From<Vec<$t>> for Voxels {
            fn from(data: Vec<$t>) -> Voxels {
                Voxels::$v(Buf::from(data))
            }
        }
        impl From<Buf<$t>> for Voxels {
            fn from(data: Buf<$t>) -> Voxels {
                Voxels::$v(data)
            }
        }
    };
}
from_vec!(u8, U8);
from_vec!(i8, I8);
from_vec!(u16, U16);
from_vec!(i16, I16);
from_vec!(f32, F32);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatch_keeps_the_type() {
        let v = Voxels::from(vec![1u16, 65535]);
        assert_eq!(v.scalar_type(), ScalarType::U16);
        assert_eq!(v.bytes(), 4);
        assert_eq!(v.get(1), 65535.0);
        assert_eq!(v.to_f32_vec(), vec![1.0, 65535.0]);
        struct Max;
        impl VoxelVisitor for Max {
            type Output = f32;
            fn visit<T: Voxel>(self, data: &[T]) -> f32 {
                data.iter().map(|v| v.to_f32()).fold(f32::NEG_INFINITY, f32::max)
            }
        }
        assert_eq!(Voxels::from(vec![-3i8, 7, 2]).visit(Max), 7.0);
        assert_eq!(1.5f32.swap_bytes().swap_bytes(), 1.5);
        assert_eq!(Voxel::swap_bytes(0x0102u16), 0x0201);
    }

    #[test]
    fn zeroed_buffers_fill_as_bytes() {
        let mut b = Buf::<i16>::zeroed(2);
        b.bytes_mut().copy_from_slice(&[0xff, 0xff, 0x02, 0x00]);
        assert_eq!(&b[..], &[i16::from_ne_bytes([0xff, 0xff]), i16::from_ne_bytes([0x02, 0x00])]);
    }
}
