//! Typed kernel bindings: one declaration per kernel (issue 36 §2), the counterpart of
//! [`crate::kernel_params!`] for buffers.
//!
//! Before, a binding's name was written three times — in `Kernel::bindings()`, in the CPU kernel's
//! `ctx.read::<T>("…")` / `ctx.put("…", v)`, and in the node's `.read("…", id)` / `.write("…", id)` —
//! and a mismatch surfaced only when the session was built (`KernelRegistry::check_pass`).
//! [`kernel_bindings!`] declares them once:
//!
//! ```ignore
//! wedge::backends::kernel_bindings! {
//!     /// What a `fog.apply` pass binds.
//!     pub struct FogIo / FogData {
//!         read color: [f32; 3],
//!         read position: [f32; 4],
//!         /// Optional: per-pixel sample counts.
//!         read_opt counts: u32,
//!         write out: [f32; 3],
//!         write_opt depth: f32,
//!     }
//! }
//! ```
//!
//! which makes two structs with one field per binding:
//! - `FogIo`, the node side: a [`BufferId`](wedge_graph::BufferId) per binding
//!   (`Option<BufferId>` for `read_opt` / `write_opt`). `FogIo { .. }.bind(pass)` calls the
//!   pass builder's `.read`/`.read_opt`/`.write` with the declared names, so the compiler makes the
//!   node give every binding and no name can be misspelt. `FogIo::bindings()` is what
//!   `Kernel::bindings` returns (declaration order; the format is the texel type's
//!   [`Texel::FORMAT`](crate::Texel::FORMAT), a [`crate::record!`] type for a struct format).
//! - `FogData<'a>`, the CPU side, from `FogIo::read(ctx)?`: a `&'a [T]` per `read` (an
//!   `Option<&'a [T]>` per `read_opt`, `None` where the pass left it unbound) and an [`Output<T>`]
//!   per `write` (`Option<Output<T>>` per `write_opt`, `None` where unbound, which is how a kernel
//!   skips work nobody reads): `data.out.put(ctx, vec)?`, `data.depth.put_with(ctx, || vec)?`
//!   ([`PutWith`]: computed only where bound). The reads borrow the pass's buffers, not
//!   the context, so the kernel keeps `&mut ctx` for its writes.
//!
//! `FogIo::new(color, position, out)` takes the required bindings in declaration order and leaves
//! every optional one unbound, so a node with many optional bindings names only those it wants:
//! `FogIo { counts: Some(id), ..FogIo::new(color, position, out) }`.
//!
//! A per-sample (layered) binding needs nothing more: its slice holds `layers` elements per pixel
//! and [`Output::layers`] says how many the write expects.

use std::marker::PhantomData;

use crate::buffer::Texel;
use crate::kernel::KernelCtx;
use crate::BackendError;

/// A kernel's write binding of `T`, typed (from a [`kernel_bindings!`] block's `read`): hand the
/// pass's output back with [`Output::put`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Output<'a, T> {
    name: &'static str,
    /// The pass it belongs to (`'a`, the context's: the data struct holds no borrow otherwise when a
    /// kernel only writes).
    pass: PhantomData<&'a ()>,
    texel: PhantomData<fn(T)>,
}

impl<T: Texel> Output<'_, T> {
    /// The write binding `name` (the generated `read` makes these).
    pub fn new(name: &'static str) -> Self {
        Output { name, pass: PhantomData, texel: PhantomData }
    }
    /// The write binding `name`, which the pass must bind (refused as [`KernelCtx::put`] would).
    pub fn required(ctx: &KernelCtx<'_>, name: &'static str) -> Result<Self, BackendError> {
        match ctx.is_bound(name) {
            true => Ok(Output::new(name)),
            false => Err(ctx.err(format!("writes `{name}`, which is not bound"))),
        }
    }
    /// The write binding `name` where the pass binds it (an optional output), else `None`.
    pub fn bound(ctx: &KernelCtx<'_>, name: &'static str) -> Option<Self> {
        ctx.is_bound(name).then(|| Output::new(name))
    }
    /// The binding's name.
    pub fn name(&self) -> &'static str {
        self.name
    }
    /// Elements per pixel the pass expects ([`KernelCtx::layers`]: 1 for an image).
    pub fn layers(&self, ctx: &KernelCtx<'_>) -> u32 {
        ctx.layers(self.name)
    }
    /// Storage to fill in place and hand back with [`Output::put`] ([`KernelCtx::output_vec`]: the
    /// pool's recycled buffer where one fits).
    pub fn storage(&self, ctx: &mut KernelCtx<'_>) -> Result<Vec<T>, BackendError> {
        ctx.output_vec(self.name)
    }
    /// Hand back the output: `layers` elements per pixel ([`KernelCtx::put`]).
    pub fn put(self, ctx: &mut KernelCtx<'_>, data: Vec<T>) -> Result<(), BackendError> {
        ctx.put(self.name, data)
    }
}

/// An optional write binding (`write_opt`) handed back only where the pass binds it: the data is
/// computed only then (what [`KernelCtx::put_opt`] did by name).
pub trait PutWith<T> {
    /// Hand back `data()` if the binding is bound; nothing otherwise.
    fn put_with(self, ctx: &mut KernelCtx<'_>, data: impl FnOnce() -> Vec<T>) -> Result<(), BackendError>;
    /// Storage to fill in place where the binding is bound ([`Output::storage`]), else `None`.
    fn storage(&self, ctx: &mut KernelCtx<'_>) -> Result<Option<Vec<T>>, BackendError>;
    /// Hand back `data` filled from [`PutWith::storage`] (nothing where unbound).
    fn put_some(self, ctx: &mut KernelCtx<'_>, data: Option<Vec<T>>) -> Result<(), BackendError>;
}

impl<T: Texel> PutWith<T> for Option<Output<'_, T>> {
    fn storage(&self, ctx: &mut KernelCtx<'_>) -> Result<Option<Vec<T>>, BackendError> {
        self.as_ref().map(|out| out.storage(ctx)).transpose()
    }
    fn put_some(self, ctx: &mut KernelCtx<'_>, data: Option<Vec<T>>) -> Result<(), BackendError> {
        match (self, data) {
            (Some(out), Some(data)) => out.put(ctx, data),
            _ => Ok(()),
        }
    }
    fn put_with(self, ctx: &mut KernelCtx<'_>, data: impl FnOnce() -> Vec<T>) -> Result<(), BackendError> {
        match self {
            Some(out) => out.put(ctx, data()),
            None => Ok(()),
        }
    }
}

/// Declare a kernel's bindings once (see [`crate::bindings`]): `struct Ids / Data { access name:
/// Texel, .. }` with access `read`, `read_opt`, `write` or `write_opt` (the [`crate::Binding`]
/// constructors'), doc comments allowed on the block and on each binding.
#[macro_export]
macro_rules! kernel_bindings {
    (
        $(#[$meta:meta])*
        $vis:vis struct $ids:ident / $data:ident {
            $( $(#[$fmeta:meta])* $access:ident $field:ident : $ty:ty ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        /// The node side: one buffer per binding; [`Self::bind`] adds them to a pass.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        $vis struct $ids {
            $( $(#[$fmeta])* pub $field: $crate::kernel_bindings!(@id $access), )*
        }
        $(#[$meta])*
        /// The CPU side: the pass's inputs as typed slices, its outputs as typed handles.
        #[allow(dead_code)]
        $vis struct $data<'a> {
            $( $(#[$fmeta])* pub $field: $crate::kernel_bindings!(@data $access 'a $ty), )*
        }
        impl $ids {
            /// The kernel's bindings, in declaration order (`Kernel::bindings`).
            pub fn bindings() -> Vec<$crate::Binding> {
                vec![$( $crate::Binding::$access(stringify!($field), <$ty as $crate::Texel>::FORMAT) ),*]
            }
            /// `b` with every binding bound by its declared name.
            pub fn bind<'c, 'a>(self, b: $crate::__graph::PassBuilder<'c, 'a>) -> $crate::__graph::PassBuilder<'c, 'a> {
                $( let b = $crate::kernel_bindings!(@bind $access b, stringify!($field), self.$field); )*
                b
            }
            /// The pass's buffers, typed (a wrong format is refused naming the binding).
            pub fn read<'a>(ctx: &$crate::KernelCtx<'a>) -> Result<$data<'a>, $crate::BackendError> {
                Ok($data { $( $field: $crate::kernel_bindings!(@read $access ctx, stringify!($field), $ty), )* })
            }
            $crate::kernel_bindings!(@new $ids [] [] $($access $field,)*);
        }
    };
    // `new`: one parameter per required binding, in declaration order; the optional ones unbound.
    (@new $ids:ident [$($p:tt)*] [$($i:tt)*]) => {
        /// Every required binding given (declaration order), every optional one unbound: a pass
        /// names the optional ones it wants with `Ids { x: Some(id), ..Ids::new(..) }`.
        #[allow(dead_code, clippy::new_without_default, clippy::too_many_arguments)]
        pub fn new($($p)*) -> $ids {
            $ids { $($i)* }
        }
    };
    (@new $ids:ident [$($p:tt)*] [$($i:tt)*] read $f:ident, $($rest:tt)*) => {
        $crate::kernel_bindings!(@new $ids [$($p)* $f: $crate::__graph::BufferId,] [$($i)* $f,] $($rest)*);
    };
    (@new $ids:ident [$($p:tt)*] [$($i:tt)*] write $f:ident, $($rest:tt)*) => {
        $crate::kernel_bindings!(@new $ids [$($p)* $f: $crate::__graph::BufferId,] [$($i)* $f,] $($rest)*);
    };
    (@new $ids:ident [$($p:tt)*] [$($i:tt)*] $opt:ident $f:ident, $($rest:tt)*) => {
        $crate::kernel_bindings!(@new $ids [$($p)*] [$($i)* $f: None,] $($rest)*);
    };
    (@id read) => { $crate::__graph::BufferId };
    (@id write) => { $crate::__graph::BufferId };
    (@id read_opt) => { Option<$crate::__graph::BufferId> };
    (@id write_opt) => { Option<$crate::__graph::BufferId> };
    (@data read $a:lifetime $ty:ty) => { &$a [$ty] };
    (@data read_opt $a:lifetime $ty:ty) => { Option<&$a [$ty]> };
    (@data write $a:lifetime $ty:ty) => { $crate::bindings::Output<$a, $ty> };
    (@data write_opt $a:lifetime $ty:ty) => { Option<$crate::bindings::Output<$a, $ty>> };
    (@bind read $b:ident, $name:expr, $id:expr) => { $b.read($name, $id) };
    (@bind read_opt $b:ident, $name:expr, $id:expr) => { $b.read_opt($name, $id) };
    (@bind write $b:ident, $name:expr, $id:expr) => { $b.write($name, $id) };
    (@bind write_opt $b:ident, $name:expr, $id:expr) => {
        match $id {
            Some(id) => $b.write($name, id),
            None => $b,
        }
    };
    (@read read $ctx:ident, $name:expr, $ty:ty) => { $ctx.read::<$ty>($name)? };
    (@read read_opt $ctx:ident, $name:expr, $ty:ty) => { $ctx.read_opt::<$ty>($name)? };
    (@read write $ctx:ident, $name:expr, $ty:ty) => { $crate::bindings::Output::<$ty>::required($ctx, $name)? };
    (@read write_opt $ctx:ident, $name:expr, $ty:ty) => { $crate::bindings::Output::<$ty>::bound($ctx, $name) };
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use wedge_graph::{BufferId, ExpandCtx, Expansion, Format, Stage};

    use super::PutWith;
    use crate::buffer::BufferData;
    use crate::kernel::{Binding, Counters, KernelCtx, Silent};

    kernel_bindings! {
        /// A test block: every access kind.
        struct TestIo / TestData {
            read position: [f32; 4],
            /// Per-pixel counts, optional.
            read_opt counts: u32,
            write out: [f32; 4],
            write_opt depth: f32,
        }
    }

    #[test]
    fn the_generated_list_is_the_hand_written_one() {
        let hand = [
            Binding::read("position", Format::Vec4),
            Binding::read_opt("counts", Format::U32),
            Binding::write("out", Format::Vec4),
            Binding::write_opt("depth", Format::F32),
        ];
        let generated = TestIo::bindings();
        assert_eq!(format!("{generated:?}"), format!("{hand:?}"));
    }

    #[test]
    fn new_takes_the_required_bindings_and_leaves_the_optional_ones_unbound() {
        let io = TestIo::new(BufferId(0), BufferId(1));
        assert_eq!(io, TestIo { position: BufferId(0), counts: None, out: BufferId(1), depth: None });
    }

    #[test]
    fn bind_names_every_binding_and_skips_unconnected_optionals() {
        let (params, inputs, mut expansion) = (BTreeMap::new(), BTreeMap::new(), Expansion::default());
        let mut ctx = ExpandCtx::new("n", &params, &inputs, &mut expansion);
        let io = TestIo { position: BufferId(0), counts: None, out: BufferId(1), depth: Some(BufferId(2)) };
        io.bind(ctx.pass("p", "k", Stage::Filter)).finish();
        let pass = &expansion.passes[0];
        assert_eq!(pass.reads, [("position".to_string(), BufferId(0))]);
        assert_eq!(pass.writes, [("out".to_string(), BufferId(1)), ("depth".to_string(), BufferId(2))]);
    }

    /// A 2×1 context reading `reads` and writing `out` (and `depth` where `depth`).
    fn run(reads: BTreeMap<String, &BufferData>, depth: bool, f: impl FnOnce(&mut KernelCtx<'_>)) {
        let scene = wedge_scene::load(&wedge_scene::SceneSource::Builtin("grids".into())).unwrap();
        let (params, counters) = (BTreeMap::new(), Counters::default());
        let mut writes = BTreeMap::from([("out".to_string(), None)]);
        if depth {
            writes.insert("depth".to_string(), None);
        }
        let mut ctx = KernelCtx::new(2, 1, 0, &scene, "t.pass", &params, &counters, &Silent, reads, writes);
        f(&mut ctx);
    }

    #[test]
    fn read_gives_typed_slices_and_outputs() {
        let position = BufferData::Vec4(vec![[1.0; 4], [2.0; 4]]);
        run(BTreeMap::from([("position".to_string(), &position)]), false, |ctx| {
            let io = TestIo::read(ctx).unwrap();
            assert_eq!(io.position[1], [2.0; 4]);
            assert!(io.counts.is_none() && io.depth.is_none(), "unbound optionals are None");
            io.depth.put_with(ctx, || unreachable!("not computed where unbound")).unwrap();
            io.out.put(ctx, vec![[0.5; 4]; 2]).unwrap();
        });
        let counts = BufferData::U32(vec![3, 4]);
        run(BTreeMap::from([("position".to_string(), &position), ("counts".to_string(), &counts)]), true, |ctx| {
            let io = TestIo::read(ctx).unwrap();
            assert_eq!(io.counts, Some(&[3u32, 4][..]));
            assert!(io.depth.put_with(ctx, || vec![1.0, 2.0]).is_ok());
        });
    }

    #[test]
    fn a_wrong_format_is_refused_as_before() {
        let position = BufferData::F32(vec![1.0, 2.0]);
        run(BTreeMap::from([("position".to_string(), &position)]), false, |ctx| {
            let typed = TestIo::read(ctx).err().unwrap().to_string();
            let by_hand = ctx.read::<[f32; 4]>("position").err().unwrap().to_string();
            assert_eq!(typed, by_hand);
            assert!(typed.contains("`position` is f32, not vec4"), "{typed}");
        });
    }
}
