//! `bevy::platform::time::Instant`, as `std`'s.

/// Bevy's platform layer.
pub mod platform {
    /// Time.
    pub mod time {
        pub use std::time::Instant;
    }
}
