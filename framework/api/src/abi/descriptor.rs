//! What a plugin library exports: the [`PluginDescriptor`] with its [`DescriptorHeader`] (read
//! before anything else), and the [`export_joint_plugin!`](crate::export_joint_plugin) macro that
//! makes one for a plugin type.

use core::ffi::{CStr, c_char};

use super::entry_points::{PluginVTable, shim_activate, shim_configure, shim_control, shim_create, shim_deactivate, shim_destroy, shim_observe};
use super::{ABI_MAGIC, ABI_MAJOR, ABI_MINOR, API_VERSION_C, LAYOUT_HASH};
use crate::JointPlugin;

/// The part of a descriptor that never changes shape, read before anything else.
///
/// Its fields are private: a header is only made by [`PluginDescriptor::new`] (this host's
/// versions and hash) or changed through [`PluginDescriptor::with_versions`], so safe code can
/// never point `api_version` at memory that is not a NUL-terminated string.
#[repr(C)]
#[derive(Debug)]
pub struct DescriptorHeader {
    pub(super) magic: u64,
    pub(super) abi_major: u32,
    pub(super) abi_minor: u32,
    pub(super) layout_hash: u64,
    pub(super) api_version: *const c_char,
}

impl DescriptorHeader {
    /// Must equal [`ABI_MAGIC`].
    pub const fn magic(&self) -> u64 {
        self.magic
    }

    /// [`ABI_MAJOR`] of the library.
    pub const fn abi_major(&self) -> u32 {
        self.abi_major
    }

    /// [`ABI_MINOR`] of the library.
    pub const fn abi_minor(&self) -> u32 {
        self.abi_minor
    }

    /// [`LAYOUT_HASH`] of the library: the shared types, entry-point signatures and constants.
    pub const fn layout_hash(&self) -> u64 {
        self.layout_hash
    }

    /// The `jointctl-api` version the library was built with.
    ///
    /// ```
    /// # use jointctl_api::*;
    /// # struct P;
    /// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
    /// export_joint_plugin!(name: p, plugin: P, dof: 1, encoders: "output", drives: "motor");
    /// assert_eq!(plugin_descriptor().header().api_version(), env!("CARGO_PKG_VERSION"));
    /// ```
    pub fn api_version(&self) -> &str {
        // SAFETY: `api_version` is only ever set from `API_VERSION_C`, a `'static` C string
        // (the fields are private and every constructor sets it so).
        unsafe { c_text(self.api_version) }
    }
}

/// Reads a C string the safe constructors made.
///
/// # Safety
/// `ptr` is null or points at a NUL-terminated string that outlives `'a`.
unsafe fn c_text<'a>(ptr: *const c_char) -> &'a str {
    if ptr.is_null() {
        return "";
    }
    // SAFETY: guaranteed by the caller.
    unsafe { CStr::from_ptr(ptr) }.to_str().unwrap_or("<not UTF-8>")
}

/// What a plugin library exports.
///
/// Every field is private: a descriptor is made only by [`PluginDescriptor::new`], whose strings
/// are `&'static CStr`, so safe code cannot make one whose strings lack their NUL or point at
/// freed memory. A descriptor read from a library is trusted only after
/// `jointctl_runtime::loader::check_descriptor` compared its header with this host's.
///
/// The safe API cannot take a string without its NUL, nor set a field:
///
/// ```compile_fail
/// # use jointctl_api::*;
/// # struct P;
/// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
/// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
/// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
/// static D: abi::PluginDescriptor = abi::PluginDescriptor::new::<P>("fixed", c"1", 1, c"output", c"motor", true);
/// ```
///
/// ```compile_fail
/// # use jointctl_api::*;
/// # struct P;
/// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
/// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
/// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
/// let mut d = abi::PluginDescriptor::new::<P>(c"fixed", c"1", 1, c"output", c"motor", true);
/// d.name = b"fixed".as_ptr().cast();
/// ```
///
/// while the same descriptor with C strings is fine:
///
/// ```
/// # use jointctl_api::*;
/// # struct P;
/// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
/// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
/// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
/// static D: abi::PluginDescriptor = abi::PluginDescriptor::new::<P>(c"fixed", c"1", 1, c"output", c"motor", true);
/// assert_eq!(D.name(), "fixed");
/// ```
#[repr(C)]
#[derive(Debug)]
pub struct PluginDescriptor {
    pub(super) header: DescriptorHeader,
    pub(super) name: *const c_char,
    pub(super) version: *const c_char,
    pub(super) built_with_unwind: u8,
    pub(super) torque_dofs: u8,
    pub(super) stiffness_dofs: u8,
    _reserved: u8,
    pub(super) dof: u32,
    pub(super) encoder_roles: *const c_char,
    pub(super) drive_roles: *const c_char,
    pub(super) vtable: PluginVTable,
}

// SAFETY: the pointers in a descriptor point at `'static` immutable strings (see `new`).
unsafe impl Sync for PluginDescriptor {}

impl PluginDescriptor {
    /// The descriptor of plugin type `P`. Used by [`export_joint_plugin!`](crate::export_joint_plugin).
    /// Roles are comma-separated; a trailing `?` marks a role optional.
    pub const fn new<P: JointPlugin>(
        name: &'static CStr,
        version: &'static CStr,
        dof: u32,
        encoder_roles: &'static CStr,
        drive_roles: &'static CStr,
        built_with_unwind: bool,
    ) -> Self {
        PluginDescriptor {
            header: DescriptorHeader {
                magic: ABI_MAGIC,
                abi_major: ABI_MAJOR,
                abi_minor: ABI_MINOR,
                layout_hash: LAYOUT_HASH,
                api_version: API_VERSION_C.as_ptr(),
            },
            name: name.as_ptr(),
            version: version.as_ptr(),
            built_with_unwind: built_with_unwind as u8,
            torque_dofs: 0,
            stiffness_dofs: 0,
            _reserved: 0,
            dof,
            encoder_roles: encoder_roles.as_ptr(),
            drive_roles: drive_roles.as_ptr(),
            vtable: PluginVTable {
                create: shim_create::<P>,
                configure: shim_configure::<P>,
                activate: shim_activate::<P>,
                observe: shim_observe::<P>,
                control: shim_control::<P>,
                deactivate: shim_deactivate::<P>,
                destroy: shim_destroy::<P>,
            },
        }
    }

    /// The same descriptor claiming other ABI versions and layout hash: how a library built
    /// against another `jointctl-api` looks to this host (the loader's refusal tests use it).
    /// Only numbers change, so it is safe.
    ///
    /// ```
    /// # use jointctl_api::*;
    /// # struct P;
    /// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
    /// let d = abi::PluginDescriptor::new::<P>(c"p", c"1", 1, c"output", c"motor", true)
    ///     .with_versions(abi::ABI_MAJOR + 1, 0, abi::LAYOUT_HASH);
    /// assert_eq!(d.header().abi_major(), abi::ABI_MAJOR + 1);
    /// ```
    pub const fn with_versions(mut self, abi_major: u32, abi_minor: u32, layout_hash: u64) -> Self {
        self.header.abi_major = abi_major;
        self.header.abi_minor = abi_minor;
        self.header.layout_hash = layout_hash;
        self
    }

    /// Checked first: magic, versions, layout hash.
    pub const fn header(&self) -> &DescriptorHeader {
        &self.header
    }

    /// The plugin name (the name YAML uses).
    pub fn name(&self) -> &str {
        // SAFETY: set only from a `&'static CStr` in `new` (fields are private).
        unsafe { c_text(self.name) }
    }

    /// The plugin crate's version.
    pub fn version(&self) -> &str {
        // SAFETY: as in `name`.
        unsafe { c_text(self.version) }
    }

    /// Comma-separated encoder roles; a trailing `?` marks a role optional.
    pub fn encoder_roles(&self) -> &str {
        // SAFETY: as in `name`.
        unsafe { c_text(self.encoder_roles) }
    }

    /// Comma-separated drive roles; a trailing `?` marks a role optional.
    pub fn drive_roles(&self) -> &str {
        // SAFETY: as in `name`.
        unsafe { c_text(self.drive_roles) }
    }

    /// Degrees of freedom one instance handles.
    pub const fn dof(&self) -> u32 {
        self.dof
    }

    /// Built with `panic = "unwind"`, so that its panics can be caught at the boundary.
    pub const fn built_with_unwind(&self) -> bool {
        self.built_with_unwind != 0
    }

    /// The same descriptor declaring what its DOFs can do, one bit per DOF (bit 0: the first
    /// DOF): which observe their torque (so torque and impedance control can run on them) and
    /// which have a stiffness that commands can set (variable stiffness joints). The host
    /// refuses commands a DOF cannot carry out.
    ///
    /// ```
    /// # use jointctl_api::*;
    /// # struct P;
    /// # impl Observer for P { fn observe(&mut self, _: &RawJointView, _: &mut [JointState]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl Controller for P { fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView, _: &mut [MotorSetpoint]) -> Result<(), JointFault> { Ok(()) } }
    /// # impl JointPlugin for P { fn create(_: &str) -> Result<Self, PluginError> { Ok(P) } }
    /// export_joint_plugin!(name: p, plugin: P, dof: 2, encoders: "a", drives: "m", torque_dofs: 0b01, stiffness_dofs: 0b01);
    /// let d = plugin_descriptor();
    /// assert!(d.observes_torque(0) && d.sets_stiffness(0));
    /// assert!(!d.observes_torque(1) && !d.sets_stiffness(1));
    /// ```
    pub const fn with_capabilities(mut self, torque_dofs: u8, stiffness_dofs: u8) -> Self {
        self.torque_dofs = torque_dofs;
        self.stiffness_dofs = stiffness_dofs;
        self
    }

    /// Whether DOF `dof` observes its torque.
    pub const fn observes_torque(&self, dof: usize) -> bool {
        dof < 8 && self.torque_dofs & (1 << dof) != 0
    }

    /// Whether DOF `dof`'s stiffness can be set by a command.
    pub const fn sets_stiffness(&self, dof: usize) -> bool {
        dof < 8 && self.stiffness_dofs & (1 << dof) != 0
    }

    /// Entry points. Calling them is `unsafe`: see [`PluginVTable`].
    pub const fn vtable(&self) -> &PluginVTable {
        &self.vtable
    }
}

/// Exports a [`JointPlugin`] type from a library crate (`crate-type = ["cdylib", "rlib"]`).
///
/// Generates the `extern "C"` entry `jointctl_plugin_<name>` that the host loads with
/// `libloading`, and `plugin_descriptor()` for linking the same plugin statically. Encoder and
/// drive roles are comma-separated; a trailing `?` marks a role optional.
///
/// ```
/// use jointctl_api::*;
/// struct Fixed;
/// impl Observer for Fixed {
///     fn observe(&mut self, raw: &RawJointView, out: &mut [JointState]) -> Result<(), JointFault> {
///         if let Some(q) = raw.encoder(0).usable(0.1) { out[0].set_position(q); }
///         Ok(())
///     }
/// }
/// impl Controller for Fixed {
///     fn control(&mut self, _: &[JointState], _: &[JointCommand], _: &RawJointView,
///                out: &mut [MotorSetpoint]) -> Result<(), JointFault> {
///         out[0] = MotorSetpoint::HOLD;
///         Ok(())
///     }
/// }
/// impl JointPlugin for Fixed {
///     fn create(_: &str) -> Result<Self, PluginError> { Ok(Fixed) }
/// }
/// export_joint_plugin!(name: fixed, plugin: Fixed, dof: 1, encoders: "output", drives: "motor");
/// assert_eq!(plugin_descriptor().name(), "fixed");
/// ```
#[macro_export]
macro_rules! export_joint_plugin {
    (
        name: $name:ident, plugin: $ty:ty, dof: $dof:literal, encoders: $enc:literal, drives: $drv:literal
        $(, torque_dofs: $torque:expr)? $(, stiffness_dofs: $stiffness:expr)? $(,)?
    ) => {
        #[doc(hidden)]
        pub static __JOINTCTL_DESCRIPTOR: $crate::abi::PluginDescriptor = $crate::abi::PluginDescriptor::new::<$ty>(
            $crate::abi::c_string(concat!(stringify!($name), "\0")),
            $crate::abi::c_string(concat!(env!("CARGO_PKG_VERSION"), "\0")),
            $dof,
            $crate::abi::c_string(concat!($enc, "\0")),
            $crate::abi::c_string(concat!($drv, "\0")),
            cfg!(panic = "unwind"),
        )
        .with_capabilities(0 $(| $torque)?, 0 $(| $stiffness)?);

        /// This plugin's descriptor, for linking it statically into a host.
        pub fn plugin_descriptor() -> &'static $crate::abi::PluginDescriptor {
            &__JOINTCTL_DESCRIPTOR
        }

        #[doc(hidden)]
        #[unsafe(export_name = concat!("jointctl_plugin_", stringify!($name)))]
        pub extern "C" fn __jointctl_plugin_entry() -> *const $crate::abi::PluginDescriptor {
            &__JOINTCTL_DESCRIPTOR
        }
    };
}
