//! Reports: the papers' figures redrawn from the database only (a query, a plot in SVG and PNG,
//! a CSV of the plotted data, a text table), and which jobs a figure still lacks.

mod campaign;
mod missing;
mod plot;
mod render;
mod silo;
mod silo_data;
mod silo_normalise;
mod table;

pub use campaign::{find_campaign, CampaignRef};
pub use missing::{campaign_completion, Completion};
pub use plot::{Axis, Figure, Legend, Panel, Scale, Series, SeriesKind};
pub use render::{render_figure, FigureReport, FIGURES};
pub use table::Table;
