//! The chute observer (Soft Matter 2022): settings and geometry (`settings`), the streaming
//! state and its per-snapshot stage (`observer`), the MSD of y behind D_y (`lateral`), the rows
//! it produces (`results`) and the stage that produces them (`finish`), the verdict on the
//! flow (`flow_state`), and whether a stored profile shows ordered layers (`layering`).

mod finish;
mod flow_state;
mod lateral;
mod layering;
mod observer;
mod results;
mod settings;

pub use finish::PDF_HALF_RANGE_STD;
pub use flow_state::{FlowRecord, FlowState, MeasuredWindow, TrendTolerances};
pub use layering::{density_layering, is_layered, LAYERED_ABOVE, LAYERING_BED};
pub use observer::{ChuteObserver, ChuteSnapshot};
pub use results::{
    ChuteBlockRow, ChuteCorrelationRow, ChuteFieldRow, ChuteMsdRow, ChuteResults, ChuteSummaryRow,
    ChuteVzPdfRow,
};
pub use settings::{
    ChuteGeometry, ChuteObserverSettings, SettingProblem, CHUNK_S, MAX_ERROR_WINDOWS,
};
