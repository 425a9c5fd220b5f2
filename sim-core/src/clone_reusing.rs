//! `Clone` whose `clone_from` reuses each field's allocation.

/// Implements `Clone` for a struct field by field, with a `clone_from` that calls each field's
/// own `clone_from` (a `Vec` keeps its allocation), where a derived `clone_from` builds the whole
/// value anew. For the copies a server keeps every frame to restore a failed step: a world of a
/// million particles is hundreds of megabytes. Every field must be listed: the destructuring is
/// exhaustive, so a field added to the struct and not here does not compile.
macro_rules! clone_reusing {
    ($ty:ident { $($field:ident),* $(,)? }) => {
        impl Clone for $ty {
            fn clone(&self) -> Self {
                let Self { $($field),* } = self;
                Self { $($field: $field.clone()),* }
            }

            fn clone_from(&mut self, source: &Self) {
                let Self { $($field),* } = source;
                $(self.$field.clone_from($field);)*
            }
        }
    };
}

pub(crate) use clone_reusing;
