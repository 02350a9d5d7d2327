//! Reports: the papers' figures redrawn from the database only (a query, a plot in SVG and PNG,
//! a CSV of the plotted data, a text table), and which jobs a figure still lacks. The campaign's
//! scene picks the paper: silo (PRE 2020) or chute (Soft Matter 2022).

mod accuracy;
mod accuracy_runs;
pub mod accuracy_shift;
mod campaign;
mod chute;
pub mod claims;
mod drawn;
mod field_map;
mod font;
mod index;
mod missing;
mod output;
mod plot;
mod raster;
mod render;
mod silo;
mod streamlines;
mod table;
mod thin;

pub use crate::pooled::chute::{
    combine_point, group_points, pool_diffusion, pool_diffusion_y, pooled_points, ChutePoint,
    OverReplicas, PointBlock, PointProfiles, BULK_BED, CENTRAL_BED,
};
pub use crate::pooled::silo::{pooled_q_points, CiSource, FlowPoint, QPoint};
pub use campaign::{find_campaign, split_version, CampaignRef};
pub use index::{render_all, AllFigures};
pub use missing::{campaign_completion, Completion};
pub use output::Output;
pub use plot::{Axis, Figure, Legend, Panel, Scale, Series, SeriesKind};
pub use render::{figures_of, render_figure, render_figure_with, FigureReport, FIGURES};
pub use table::Table;

/// The silo's replicas combined into points, as fig3–fig5 combine them (campaign targets use
/// the same statistic).
pub mod silo_points {
    pub use crate::pooled::silo::{
        combine_replicas, gravity_m_per_s2, CiSource, DischargeRow, FlowPoint,
    };
}
