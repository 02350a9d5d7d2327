//! The engine's kernels: the WGSL modules they come from (common.wgsl and the files each module
//! concatenates), and per kernel its entry point and the bindings it uses (layout.rs numbers).
//! `pipelines.rs` builds layouts, pipelines and bind groups from this table.

use super::layout::binding as b;

const INTEGRATE: &str = concat!(
    include_str!("shaders/common.wgsl"),
    include_str!("shaders/inplace.wgsl"),
    include_str!("shaders/step.wgsl"),
    include_str!("shaders/integrate.wgsl"),
    include_str!("shaders/rotate.wgsl")
);
const GRID: &str = concat!(
    include_str!("shaders/common.wgsl"),
    include_str!("shaders/grid.wgsl")
);
const REORDER: &str = concat!(
    include_str!("shaders/common.wgsl"),
    include_str!("shaders/reorder.wgsl")
);
const CONTACTS: &str = concat!(
    include_str!("shaders/common.wgsl"),
    include_str!("shaders/law.wgsl"),
    include_str!("shaders/walls.wgsl"),
    include_str!("shaders/contacts.wgsl"),
    include_str!("shaders/rods.wgsl")
);
const FUSED: &str = concat!(
    include_str!("shaders/common.wgsl"),
    include_str!("shaders/law.wgsl"),
    include_str!("shaders/walls.wgsl"),
    include_str!("shaders/contacts.wgsl"),
    include_str!("shaders/rods.wgsl"),
    include_str!("shaders/step.wgsl"),
    include_str!("shaders/rotate.wgsl"),
    include_str!("shaders/fused.wgsl")
);

/// The shader modules.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Module {
    Integrate,
    Grid,
    Reorder,
    Contacts,
    /// The one-dispatch step (`GpuOptions::fused_step`), compiled only when it is asked for.
    Fused,
}

impl Module {
    pub const ALL: [Module; 5] = [
        Module::Integrate,
        Module::Grid,
        Module::Reorder,
        Module::Contacts,
        Module::Fused,
    ];

    pub fn source(self) -> &'static str {
        match self {
            Module::Integrate => INTEGRATE,
            Module::Grid => GRID,
            Module::Reorder => REORDER,
            Module::Contacts => CONTACTS,
            Module::Fused => FUSED,
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            Module::Integrate => "integrate.wgsl",
            Module::Grid => "grid.wgsl",
            Module::Reorder => "reorder.wgsl",
            Module::Contacts => "contacts.wgsl",
            Module::Fused => "fused.wgsl",
        }
    }

    /// Whether a storage binding is declared `read` (not `read_write`) in this module.
    pub fn read_only(self, binding: u32) -> bool {
        match self {
            Module::Integrate => matches!(binding, b::LOAD | b::REF_POS),
            Module::Grid => matches!(
                binding,
                b::POS_R | b::INFO | b::VEL_IM | b::OMEGA | b::LOAD | b::HIST | b::HIST_HI | b::ROD
            ),
            Module::Reorder => matches!(binding, b::CELL_START | b::SCRATCH),
            Module::Contacts => matches!(
                binding,
                b::POS_R | b::VEL_IM | b::OMEGA | b::NBR | b::NBR_HI
            ),
            Module::Fused => matches!(
                binding,
                b::POS_R | b::VEL_IM | b::OMEGA | b::NBR | b::NBR_HI | b::REF_POS
            ),
        }
    }
}

/// One compute kernel: its module, entry point and the bindings it uses.
pub struct KernelSpec {
    pub module: Module,
    pub entry: &'static str,
    pub bindings: &'static [u32],
}

/// What the contact kernels bind: both evaluate the same contacts, one to forces, one to
/// records.
const CONTACT_BINDINGS: &[u32] = &[
    b::PARAMS,
    b::WALLS,
    b::POS_R,
    b::VEL_IM,
    b::OMEGA,
    b::INFO,
    b::LOAD,
    b::HIST,
    b::HIST_HI,
    b::NBR,
    b::NBR_HI,
    b::STATUS,
    b::RECORDS,
];

/// What the one-dispatch step binds: the contact kernels' bindings, then what its kick and
/// drift read and write (the second copy of the state among them).
const FUSED_BINDINGS: [u32; CONTACT_BINDINGS.len() + 6] = concat(
    CONTACT_BINDINGS,
    &[
        b::REF_POS,
        b::EVENTS,
        b::ROD,
        b::POS_W,
        b::VEL_W,
        b::OMEGA_W,
    ],
);

/// `a` then `b`, at compile time (`N` must be their total length).
const fn concat<const N: usize>(a: &[u32], b: &[u32]) -> [u32; N] {
    assert!(a.len() + b.len() == N);
    let mut out = [0; N];
    let mut i = 0;
    while i < N {
        out[i] = if i < a.len() { a[i] } else { b[i - a.len()] };
        i += 1;
    }
    out
}

/// Kernel indices into `KERNELS`.
pub mod kernel {
    /// The step's kick and drift (and, oriented, rotation), sink and skin check.
    pub const KICK_DRIFT: usize = 0;
    pub const CLOSE_KICK: usize = 1;
    pub const FINISH: usize = 2;
    /// The six list-build passes, in execution order.
    pub const BUILD: [usize; 6] = [3, 4, 5, 6, 7, 8];
    pub const COMPUTE_FORCES: usize = 9;
    /// Contact records for observers (compiled with RECORD).
    pub const RECORD_CONTACTS: usize = 10;
    /// The chunk's fixed-point kinetic-energy sum, after `FINISH`.
    pub const ENERGY_SUM: usize = 11;
    /// Unpacks the records `scatter` packed in cell order (a build that sorts by cell).
    pub const SETTLE: usize = 12;
    /// Each particle's share of the elastic energy in the contacts (compiled with RECORD), then
    /// its fixed-point sum: the energy watchdog's U₀.
    pub const CONTACT_ENERGY: usize = 13;
    pub const ELASTIC_SUM: usize = 14;
    /// The one-dispatch step (fused.wgsl), and the second copy of the state written back to the
    /// first at a chunk's end; built only for `GpuOptions::fused_step`.
    pub const FUSED_STEP: usize = 15;
    pub const ADOPT: usize = 16;
    /// The cell-start scan's passes, which index their workgroups along x alone.
    pub const SCANS: [usize; 3] = [BUILD[1], BUILD[2], BUILD[3]];
}

/// Workgroups (x, y) of a dispatch of `groups` workgroups of kernel `k`. The per-slot kernels
/// run in rows of at most `max_x` workgroups when one row would pass the device's limit per
/// dimension (common.wgsl `flat`); the scans run in one row.
pub fn dispatch_size(k: usize, groups: u32, max_x: u32) -> (u32, u32) {
    if kernel::SCANS.contains(&k) || groups <= max_x {
        return (groups, 1);
    }
    let rows = groups.div_ceil(max_x.max(1));
    (groups.div_ceil(rows), rows)
}

/// Every kernel of the engine.
pub const KERNELS: [KernelSpec; 17] = [
    KernelSpec {
        module: Module::Integrate,
        entry: "kick_drift",
        bindings: &[
            b::PARAMS,
            b::POS_R,
            b::VEL_IM,
            b::OMEGA,
            b::INFO,
            b::LOAD,
            b::REF_POS,
            b::STATUS,
            b::EVENTS,
            b::ROD,
        ],
    },
    KernelSpec {
        module: Module::Integrate,
        entry: "close_kick",
        bindings: &[
            b::PARAMS,
            b::VEL_IM,
            b::OMEGA,
            b::INFO,
            b::LOAD,
            b::STATUS,
            b::ROD,
        ],
    },
    KernelSpec {
        module: Module::Integrate,
        entry: "finish",
        bindings: &[
            b::PARAMS,
            b::POS_R,
            b::VEL_IM,
            b::OMEGA,
            b::INFO,
            b::LOAD,
            b::STATUS,
            b::ROD,
            b::ENERGY,
        ],
    },
    KernelSpec {
        module: Module::Grid,
        entry: "histogram",
        bindings: &[
            b::PARAMS,
            b::POS_R,
            b::INFO,
            b::STATUS,
            b::CELL_RANK,
            b::CELL_COUNT,
        ],
    },
    KernelSpec {
        module: Module::Grid,
        entry: "scan_blocks",
        bindings: &[
            b::PARAMS,
            b::STATUS,
            b::CELL_COUNT,
            b::CELL_START,
            b::CHUNK_SUMS,
        ],
    },
    KernelSpec {
        module: Module::Grid,
        entry: "scan_totals",
        bindings: &[b::PARAMS, b::STATUS, b::CELL_START, b::CHUNK_SUMS],
    },
    KernelSpec {
        module: Module::Grid,
        entry: "scan_apply",
        bindings: &[b::PARAMS, b::STATUS, b::CELL_START, b::CHUNK_SUMS],
    },
    KernelSpec {
        module: Module::Grid,
        entry: "scatter",
        bindings: &[
            b::PARAMS,
            b::INFO,
            b::STATUS,
            b::CELL_RANK,
            b::CELL_START,
            b::SORTED,
            b::POS_R,
            b::VEL_IM,
            b::OMEGA,
            b::LOAD,
            b::HIST,
            b::HIST_HI,
            b::ROD,
            b::SCRATCH,
        ],
    },
    KernelSpec {
        module: Module::Grid,
        entry: "build_list",
        bindings: &[
            b::PARAMS,
            b::POS_R,
            b::INFO,
            b::NBR,
            b::NBR_HI,
            b::REF_POS,
            b::STATUS,
            b::CELL_RANK,
            b::CELL_START,
            b::SORTED,
        ],
    },
    KernelSpec {
        module: Module::Contacts,
        entry: "compute_forces",
        bindings: CONTACT_BINDINGS,
    },
    KernelSpec {
        module: Module::Contacts,
        entry: "record_contacts",
        bindings: CONTACT_BINDINGS,
    },
    KernelSpec {
        module: Module::Integrate,
        entry: "energy_sum",
        bindings: &[b::PARAMS, b::STATUS, b::ENERGY],
    },
    KernelSpec {
        module: Module::Reorder,
        entry: "settle",
        bindings: &[
            b::PARAMS,
            b::POS_R,
            b::VEL_IM,
            b::OMEGA,
            b::INFO,
            b::LOAD,
            b::HIST,
            b::HIST_HI,
            b::STATUS,
            b::CELL_START,
            b::ROD,
            b::SCRATCH,
        ],
    },
    KernelSpec {
        module: Module::Contacts,
        entry: "contact_energy",
        bindings: &[
            b::PARAMS,
            b::WALLS,
            b::POS_R,
            b::VEL_IM,
            b::OMEGA,
            b::INFO,
            b::HIST,
            b::HIST_HI,
            b::NBR,
            b::NBR_HI,
            b::STATUS,
            b::RECORDS,
            b::ENERGY,
        ],
    },
    KernelSpec {
        module: Module::Integrate,
        entry: "elastic_sum",
        bindings: &[b::PARAMS, b::STATUS, b::ENERGY],
    },
    KernelSpec {
        module: Module::Fused,
        entry: "fused_step",
        bindings: &FUSED_BINDINGS,
    },
    KernelSpec {
        module: Module::Fused,
        entry: "adopt",
        bindings: &[
            b::PARAMS,
            b::POS_R,
            b::VEL_IM,
            b::OMEGA,
            b::STATUS,
            b::POS_W,
            b::VEL_W,
            b::OMEGA_W,
        ],
    },
];

/// Kernels every engine builds; the one-dispatch step's follow (`Pipelines::new`).
pub const TWO_DISPATCH_KERNELS: usize = kernel::FUSED_STEP;
