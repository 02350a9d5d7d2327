//! Contact history: the tangential spring of every contact a particle has, keyed by the partner's
//! stable id (a particle id, or a wall's id from `wall_key`). This per-particle table is the
//! exchange format (checkpoints, GPU, spherocylinders): it lives with the particle, so it survives
//! re-sorting and removal. A pair's spring is stored twice (i's view and j's view), mirror images
//! (exact negatives when the sphere step wrote them; up to rounding from the GPU). The sphere step
//! keeps springs per pair while a chunk runs (`cpu/half_lists.rs`) and writes them back here.

use super::real::{Real, V3};

/// Partner key marking an empty slot.
pub const EMPTY: u32 = u32::MAX;

/// Key of wall `w` in the history table (particle ids stay below 2³¹).
pub fn wall_key(w: usize) -> u32 {
    0x8000_0000 | w as u32
}

/// Fixed number of slots per particle.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct History<R: Real> {
    pub slots: usize,
    pub partner: Vec<u32>,
    pub spring: Vec<V3<R>>,
}

impl<R: Real> History<R> {
    pub fn new(slots: usize) -> Self {
        Self {
            slots,
            partner: Vec::new(),
            spring: Vec::new(),
        }
    }

    pub fn push_particle(&mut self) {
        self.partner.extend(std::iter::repeat_n(EMPTY, self.slots));
        self.spring
            .extend(std::iter::repeat_n(V3::zero(), self.slots));
    }

    pub fn permute(&mut self, order: &[u32]) {
        if self.slots == 0 {
            return;
        }
        let k = self.slots;
        let mut partner = Vec::with_capacity(order.len() * k);
        let mut spring = Vec::with_capacity(order.len() * k);
        for &o in order {
            let o = o as usize;
            partner.extend_from_slice(&self.partner[o * k..(o + 1) * k]);
            spring.extend_from_slice(&self.spring[o * k..(o + 1) * k]);
        }
        self.partner = partner;
        self.spring = spring;
    }

    /// The spring particle `i` stores for partner `key`, or zero when it has none (read-only:
    /// the energy watchdog reads springs without advancing them).
    pub fn spring_of(&self, i: usize, key: u32) -> V3<R> {
        let row = i * self.slots..(i + 1) * self.slots;
        for (&p, &s) in self.partner[row.clone()].iter().zip(&self.spring[row]) {
            if p == key {
                return s;
            }
            if p == EMPTY {
                break;
            }
        }
        V3::zero()
    }

    pub fn convert<S: Real>(&self) -> History<S> {
        History {
            slots: self.slots,
            partner: self.partner.clone(),
            spring: self
                .spring
                .iter()
                .map(|v| V3::from_f64(v.to_f64()))
                .collect(),
        }
    }
}

/// A particle's rows while its forces are computed: old springs are looked up by partner key and
/// the rows are rewritten with only the contacts that still exist (in neighbour order).
pub struct Rows<'a, R: Real> {
    partner: &'a mut [u32],
    spring: &'a mut [V3<R>],
    old_partner: [u32; MAX_SLOTS],
    old_spring: [V3<R>; MAX_SLOTS],
    old_len: usize,
    len: usize,
}

/// Largest number of simultaneous contacts per particle the table can hold.
pub const MAX_SLOTS: usize = 16;

/// History slots per particle that scenes and the CPU engine allocate (spheres rarely exceed 12
/// contacts plus walls): the width of the state's table, so of checkpoints and GPU uploads.
pub const HISTORY_SLOTS: usize = 16;
const _: () = assert!(HISTORY_SLOTS <= MAX_SLOTS);

impl<'a, R: Real> Rows<'a, R> {
    pub fn open(partner: &'a mut [u32], spring: &'a mut [V3<R>]) -> Self {
        // Rows are kept packed (contacts first, then EMPTY), so the old contacts are a prefix.
        let mut old_partner = [EMPTY; MAX_SLOTS];
        let mut old_spring = [V3::zero(); MAX_SLOTS];
        let mut old_len = 0;
        while old_len < partner.len() && partner[old_len] != EMPTY {
            old_partner[old_len] = partner[old_len];
            old_spring[old_len] = spring[old_len];
            old_len += 1;
        }
        Self {
            partner,
            spring,
            old_partner,
            old_spring,
            old_len,
            len: 0,
        }
    }

    /// The spring stored for `key`, or zero for a new contact.
    #[inline]
    pub fn get(&self, key: u32) -> V3<R> {
        for s in 0..self.old_len {
            if self.old_partner[s] == key {
                return self.old_spring[s];
            }
        }
        V3::zero()
    }

    /// Records the updated spring of a contact that exists this step. Returns false when the
    /// table is full (the caller reports it: a contact without history would be silently wrong).
    #[inline]
    pub fn put(&mut self, key: u32, spring: V3<R>) -> bool {
        if self.len >= self.partner.len() {
            return false;
        }
        self.partner[self.len] = key;
        self.spring[self.len] = spring;
        self.len += 1;
        true
    }
}

impl<R: Real> Drop for Rows<'_, R> {
    fn drop(&mut self) {
        // Only the slots that held contacts before can be non-empty past the new length.
        for s in self.len..self.old_len.max(self.len) {
            self.partner[s] = EMPTY;
            self.spring[s] = V3::zero();
        }
    }
}
