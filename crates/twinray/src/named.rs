//! Values known by name: a closed set of choices that the command line, a
//! saved job (serde) and the reports spell one way.
//!
//! [`named_values!`] gives an enum its names (`NAMES`, `name()`), `Display`
//! and `FromStr` with them; the enum's serde names are the same
//! (`rename_all = "kebab-case"`), which a test of each enum checks.

/// `named_values!(Type { Variant = "name", ... })`: the names of a
/// field-less enum, its `Display` and its `FromStr` (an error naming every
/// value for anything else).
macro_rules! named_values {
    ($ty:ident { $($variant:ident = $name:literal),+ $(,)? }) => {
        impl $ty {
            /// Every value's name, as the command line and a saved job spell it.
            pub const NAMES: &'static [&'static str] = &[$($name),+];

            /// This value's name.
            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name),+
                }
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $ty {
            type Err = crate::Error;

            fn from_str(s: &str) -> crate::Result<Self> {
                match s {
                    $($name => Ok($ty::$variant),)+
                    _ => Err(crate::Error::Invalid(format!(
                        "'{s}': use one of {}",
                        Self::NAMES.join(", ")
                    ))),
                }
            }
        }
    };
}

pub(crate) use named_values;

/// Whether every value of `values` has the same name in serde (a saved job)
/// and in `Display` (the command line): for the tests of each named enum.
#[cfg(test)]
pub(crate) fn serde_names_agree<T>(values: &[T]) -> bool
where
    T: serde::Serialize + std::fmt::Display,
{
    values
        .iter()
        .all(|v| serde_json::to_value(v).ok() == Some(serde_json::Value::String(v.to_string())))
}
