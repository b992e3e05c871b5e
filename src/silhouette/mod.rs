//! Silhouettes (thesis 4.3.7): object-space stroke geometry.
//!
//! [`edges`] holds the CPU side: an edge-adjacency table of the strand topology built once and
//! shared by all strands, per-frame extraction of the edges between front- and back-facing
//! triangles, chaining into ordered polylines (several loops and open chains per strand, no edge
//! ever dropped, odd vertices split rather than lost), and screen-space stroke strips with the
//! thesis's angle, depth and stroke scaling, stroke limit and E-curve fade.

pub mod edges;
