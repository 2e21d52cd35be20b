//! Exploring: the scan of the grown graph for candidates, and what a
//! query does when it finds none.

use speleo_exploration::{ExplorerPhase, Pass, ReturnReason};

use crate::exploration::Exploration;
use crate::query::Phase;
use crate::trace::{trace_graph_near, GRAPH_TRACE_RADIUS_M};
use crate::{Navigator, GOAL_POINTS, SCAN_PER_UNIT};

impl Navigator {
    /// Scan the graph for exploration candidates; then plan to the best.
    pub(crate) fn candidates(&mut self, units: usize) -> Phase {
        let Some(ex) = self.explore.as_deref_mut() else {
            return Phase::Idle;
        };
        let Exploration {
            explorer,
            scan,
            counters,
            ..
        } = ex;
        let done = scan.step(
            self.lat.trav(),
            explorer.coverage(),
            explorer.rejected(),
            (units as u64).saturating_mul(SCAN_PER_UNIT),
        );
        if !done {
            return Phase::Candidates;
        }
        // Nothing with room to spare: the tight places (a squeeze's waist),
        // then the crests just over the rover, before giving up here.
        if scan.best().is_empty() && scan.next_pass() {
            return Phase::Candidates;
        }
        if scan.pass() == Pass::Crest {
            if let Some(c) = scan.best().first() {
                tracing::debug!(
                    x = c.position[0],
                    y = c.position[1],
                    z = c.position[2],
                    "a crest to look over"
                );
            }
        }
        counters.scans += 1;
        let found = !scan.best().is_empty();
        if !found
            && explorer.phase() == ExplorerPhase::Exploring
            && self.window_half_m < self.window_max_half_m
        {
            // Nothing here yet: the next query looks farther before the
            // rover turns back (at a garage ramp's top, the retrace drove
            // it back down).
            counters.scans_empty += 1;
            tracing::debug!(
                x = self.query.rover[0],
                y = self.query.rover[1],
                window_m = 2.0 * self.window_half_m,
                "no candidate in the window"
            );
            self.end_query();
            return Phase::Idle;
        }
        if matches!(explorer.phase(), ExplorerPhase::Returning(_)) {
            // Nothing new here either (or a return for the time limit, or
            // a place where exploring again was in vain): on home.
            if !found || !explorer.resume([self.query.rover[0], self.query.rover[1]]) {
                return self.goal_order();
            }
            counters.resumes += 1;
            tracing::debug!(
                x = self.query.rover[0],
                y = self.query.rover[1],
                "exploring again"
            );
        } else {
            explorer.query_result(found);
            if explorer.phase() == ExplorerPhase::Returning(ReturnReason::Explored)
                && ex.second_look()
            {
                // The next query grows its graph without the barred places.
                self.end_query();
                return Phase::Idle;
            }
        }
        let rover = [self.query.rover[0], self.query.rover[1]];
        if ex.scan.best().is_empty() && ex.explorer.resumed_in_vain(rover) {
            // Exploring again found nothing here after all: the next
            // query goes home.
            self.end_query();
            return Phase::Idle;
        }
        let best = ex.scan.best();
        if best.is_empty() {
            ex.counters.scans_empty += 1;
            let c = ex.scan.census();
            tracing::debug!(
                x = self.query.rover[0],
                y = self.query.rover[1],
                nodes = self.lat.trav().nodes().len(),
                inner = c.inner,
                beyond_margin = c.beyond_margin,
                too_near = c.too_near,
                covered = c.covered,
                rejected = c.rejected,
                cramped = c.cramped,
                no_crest = c.no_crest,
                crest_not_border = c.crest_not_border,
                crest_low = c.crest_low,
                crest_out_of_reach = c.crest_out_of_reach,
                crest_stood = c.crest_stood,
                farthest_m = c.farthest_m,
                farthest_x = c.farthest[0],
                farthest_y = c.farthest[1],
                "no candidate"
            );
            trace_graph_near(self.lat.trav(), self.query.rover, GRAPH_TRACE_RADIUS_M);
            ex.no_start();
            self.counters.no_goal += 1;
            self.end_query();
            return Phase::Idle;
        }
        let q = &mut self.query;
        q.order_len = best.len().min(GOAL_POINTS);
        for (o, c) in q.order.iter_mut().zip(best) {
            *o = (c.node, c.position);
        }
        self.try_goal(0)
    }
}
