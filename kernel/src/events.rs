//! Event counters of a simulation ([`Events`]): how often each path of
//! the step ran. They are diagnostics: not part of the digest nor of a
//! checkpoint, and results never depend on them.

/// How often each event of the step happened since [`crate::Sim::reset`]
/// (or [`crate::Sim::restore`]), saturating at `u64::MAX`. The batched and
/// the scalar step count alike. Contacts and seam crossings are counted
/// only while [`crate::Sim::count_events`] is on.
///
/// A contact is a listed pair whose normal spring e_n (docs/model.md (6))
/// is not zero: it is *made* on the step that starts its history and
/// *broken* on the step that drops it (apart, or tension (8)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Events {
    /// Contacts made: a pair without history that overlaps and acts.
    pub contacts_made: u64,
    /// Contacts broken: a pair with history that comes apart or breaks
    /// under tension (8).
    pub contacts_broken: u64,
    /// Contact-steps at the Coulomb limit (9): one per contact per step
    /// that slides.
    pub contacts_sliding: u64,
    /// Mobile grains wrapped across the periodic seam x = 0 ≡ L.
    pub seam_crossings: u64,
    /// Neighbour-list rebuilds.
    pub neighbour_rebuilds: u64,
    /// Redraws of every grain's held turbulent fluctuation (docs/model.md (15)).
    pub turbulence_redraws: u64,
    /// Updates of the mean bed level (docs/model.md §6).
    pub bed_level_updates: u64,
    /// Steps taken by the batched step (x86-64 with AVX2 and a ready pair
    /// index); the rest were scalar steps. Always 0 on other targets.
    pub batched_steps: u64,
    /// Steps taken by the phased step ([`crate::Sim::step_phased`]); those
    /// it took in vector lanes count in `batched_steps` too.
    pub phased_steps: u64,
}

impl Events {
    /// No events.
    pub const ZERO: Self = Events {
        contacts_made: 0,
        contacts_broken: 0,
        contacts_sliding: 0,
        seam_crossings: 0,
        neighbour_rebuilds: 0,
        turbulence_redraws: 0,
        bed_level_updates: 0,
        batched_steps: 0,
        phased_steps: 0,
    };

    /// Adds `other`'s counts, saturating.
    pub(crate) fn add(&mut self, other: &Events) {
        self.contacts_made = self.contacts_made.saturating_add(other.contacts_made);
        self.contacts_broken = self.contacts_broken.saturating_add(other.contacts_broken);
        self.contacts_sliding = self.contacts_sliding.saturating_add(other.contacts_sliding);
        self.seam_crossings = self.seam_crossings.saturating_add(other.seam_crossings);
        self.neighbour_rebuilds = self
            .neighbour_rebuilds
            .saturating_add(other.neighbour_rebuilds);
        self.turbulence_redraws = self
            .turbulence_redraws
            .saturating_add(other.turbulence_redraws);
        self.bed_level_updates = self
            .bed_level_updates
            .saturating_add(other.bed_level_updates);
        self.batched_steps = self.batched_steps.saturating_add(other.batched_steps);
        self.phased_steps = self.phased_steps.saturating_add(other.phased_steps);
    }
}
