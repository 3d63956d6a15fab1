//! FNV-1a mixing of bytes, token text and sizes, and the macros that hash the shared types' layouts
//! and the constants into [`LAYOUT_HASH`](super::LAYOUT_HASH).

pub(super) const fn mix_bytes(mut hash: u64, bytes: &[u8]) -> u64 {
    let mut i = 0;
    while i < bytes.len() {
        hash ^= bytes[i] as u64;
        hash = hash.wrapping_mul(0x0100_0000_01b3);
        i += 1;
    }
    hash
}

/// [`mix_bytes`] over a token text without its whitespace, which the compiler's pretty-printer
/// (`stringify!`) may lay out differently from one version to the next.
pub(super) const fn mix_tokens(mut hash: u64, text: &str) -> u64 {
    let bytes = text.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        if !bytes[i].is_ascii_whitespace() {
            hash ^= bytes[i] as u64;
            hash = hash.wrapping_mul(0x0100_0000_01b3);
        }
        i += 1;
    }
    hash
}

pub(super) const fn mix_usize(hash: u64, value: usize) -> u64 {
    mix_bytes(hash, &(value as u64).to_le_bytes())
}

/// Hashes each listed type's name, size and alignment and each field's name, offset and
/// declared type (as written). A compile-time check beside each field makes the declared type
/// the real one, so the hash cannot drift from the code: change a field's type and this list
/// must change too, and with it the hash.
macro_rules! hash_layouts {
    ($hash:ident; $($ty:ident { $($field:ident : $fty:ty),* $(,)? })*) => {
        $(
            $hash = mix_bytes($hash, stringify!($ty).as_bytes());
            $hash = mix_usize($hash, size_of::<$ty>());
            $hash = mix_usize($hash, align_of::<$ty>());
            $(
                $hash = mix_bytes($hash, stringify!($field).as_bytes());
                $hash = mix_tokens($hash, stringify!($fty));
                $hash = mix_usize($hash, offset_of!($ty, $field));
            )*
            const _: () = {
                #[allow(dead_code)]
                fn declared_types_are_the_real_ones(v: &$ty) {
                    $( let _: &$fty = &v.$field; )*
                }
            };
        )*
    };
}

/// Mixes named constants (name and value) into the hash: status codes, limits and the values
/// of the `#[repr(transparent)]` enums both sides must agree on.
macro_rules! hash_constants {
    ($hash:ident; $($name:expr),* $(,)?) => {
        $(
            $hash = mix_bytes($hash, stringify!($name).as_bytes());
            $hash = mix_bytes($hash, &($name as u64).to_le_bytes());
        )*
    };
}
