//! The edge runner for a fleet: several vehicles in one process on the one
//! tokio runtime, stepped together on one clock, each with its own links,
//! data directory, onboard log and VDA 5050 client. Link traffic of every
//! vehicle is answered between ticks as it comes, as for one vehicle.
//!
//! The loop keeps its own timer (a current-thread runtime on the calling
//! thread, time only) rather than the edge worker's: at each round's due
//! time the kernel wakes the loop's thread alone, where the worker's timer
//! woke the worker only for it to wake the loop. And what a round's ticks
//! say to the links and the broker is handed over in bursts
//! ([`RELEASE_EVERY`]), not vehicle by vehicle: each hand-over to a parked
//! worker is a wake-up, and one burst wakes it once for many vehicles.

use std::future::Future;
use std::time::Duration;

use tokio::sync::{mpsc, oneshot};

use super::clock::InstantTimer;
use super::mqtt::MqttConfig;
use super::persistence::Persistence;
use super::runner::{Edge, EdgeRunner, LinkServed};
use crate::link::hub::ToCore;
use crate::link::sockets::LinkSockets;
use crate::vehicle::Outputs;

/// Link traffic of all the vehicles waiting for the loop.
const MERGED_QUEUE: usize = 1024;

/// The longest a tick's messages wait in a round before they go to the
/// links and the broker: a round of many vehicles hands them over in a
/// few bursts, a round of one at once.
const RELEASE_EVERY: Duration = Duration::from_millis(2);

/// Vehicles stepped together: a simulated fleet sharing one world.
pub trait FleetPlatform {
    type Vehicle: LinkServed;

    fn vehicles_mut(&mut self) -> &mut [Self::Vehicle];

    /// Before a round of ticks: the vehicles are placed in each other's
    /// worlds where they are now.
    fn before_ticks(&mut self, wall: Duration);

    /// One tick of vehicle `index`.
    fn tick(&mut self, index: usize, wall: Duration, timer: &mut InstantTimer) -> &mut Outputs;

    /// After a round: how long until the next one is due (`None`: now).
    fn until_next_tick(&mut self, wall: Duration) -> Option<Duration>;

    /// The shutdown future completed: the summary logged.
    fn stop(&mut self, wall: Duration, dropped_to_links: u64);
}

/// What one vehicle of a fleet runs with besides its core.
pub struct FleetMember {
    pub sockets: LinkSockets,
    pub persistence: Persistence,
    pub mqtt: Option<MqttConfig>,
}

impl EdgeRunner {
    /// Runs `fleet`, vehicle `i` with `members[i]`, until `shutdown`
    /// completes.
    pub fn run_fleet<F: FleetPlatform>(
        self,
        fleet: &mut F,
        members: Vec<FleetMember>,
        shutdown: impl Future<Output = ()> + Send + 'static,
    ) -> Result<(), String> {
        let mut edges = Vec::with_capacity(members.len());
        for (vehicle, member) in fleet.vehicles_mut().iter().zip(members) {
            edges.push(Edge::start(
                &self,
                vehicle.core(),
                member.sockets,
                member.persistence,
                member.mqtt,
            )?);
        }
        let mut inbound = self.merge_inbound(&mut edges);
        let stop = self.stop_on(shutdown);
        let clock = tokio::runtime::Builder::new_current_thread()
            .enable_time()
            .build()
            .map_err(|e| format!("the fleet's clock: {e}"))?;
        clock.block_on(drive(fleet, &mut edges, &mut inbound, stop));
        let wall = edges.first().map_or(Duration::ZERO, Edge::wall);
        fleet.stop(wall, edges.iter().map(|e| e.dropped_to_links).sum());
        // OFFLINE from every vehicle at once, not one after another.
        let stops: Vec<_> = edges
            .iter_mut()
            .filter_map(Edge::take_mqtt)
            .map(|mqtt| self.runtime.spawn(mqtt.stop()))
            .collect();
        self.runtime.block_on(async {
            for stop in stops {
                let _ = stop.await;
            }
        });
        for edge in edges {
            edge.finish(&self.runtime);
        }
        Ok(())
    }

    /// Every vehicle's inbound link traffic into one queue, tagged with the
    /// vehicle's index, so the loop waits on one queue, not N.
    fn merge_inbound(&self, edges: &mut [Edge]) -> mpsc::Receiver<(usize, ToCore)> {
        let (merged_tx, merged) = mpsc::channel(MERGED_QUEUE);
        for (index, edge) in edges.iter_mut().enumerate() {
            let mut inbound = edge.take_inbound();
            let tx = merged_tx.clone();
            self.runtime.spawn(async move {
                while let Some(item) = inbound.recv().await {
                    if tx.send((index, item)).await.is_err() {
                        return;
                    }
                }
            });
        }
        merged
    }
}

/// The fleet's loop: a round of ticks, then link traffic answered as it
/// comes until the next round is due.
async fn drive<F: FleetPlatform>(
    fleet: &mut F,
    edges: &mut [Edge],
    inbound: &mut mpsc::Receiver<(usize, ToCore)>,
    mut stop: oneshot::Receiver<()>,
) {
    let mut timer = InstantTimer::default();
    let mut links_open = true;
    loop {
        if !matches!(stop.try_recv(), Err(oneshot::error::TryRecvError::Empty)) {
            return;
        }
        while let Ok((index, item)) = inbound.try_recv() {
            edges[index].take_link_traffic(&mut fleet.vehicles_mut()[index], Some(item));
        }
        round(fleet, edges, &mut timer);
        let Some(delay) = fleet.until_next_tick(edges[0].wall()) else {
            tokio::task::yield_now().await;
            continue;
        };
        let deadline = tokio::time::Instant::now() + delay;
        loop {
            let (index, item) = tokio::select! {
                _ = &mut stop => return,
                item = inbound.recv(), if links_open => match item {
                    Some(item) => item,
                    None => {
                        links_open = false;
                        continue;
                    }
                },
                () = tokio::time::sleep_until(deadline) => break,
            };
            edges[index].serve(&mut fleet.vehicles_mut()[index], Some(item));
        }
    }
}

/// One tick of every vehicle; their messages leave in bursts at most
/// [`RELEASE_EVERY`] apart, the last at the round's end.
fn round<F: FleetPlatform>(fleet: &mut F, edges: &mut [Edge], timer: &mut InstantTimer) {
    for (edge, vehicle) in edges.iter_mut().zip(fleet.vehicles_mut()) {
        edge.gather(vehicle);
    }
    let round_start = edges[0].wall();
    fleet.before_ticks(round_start);
    let mut released_at = round_start;
    let mut held_from = 0;
    for index in 0..edges.len() {
        let wall = edges[index].wall();
        if wall >= released_at + RELEASE_EVERY {
            edges[held_from..index].iter_mut().for_each(Edge::release);
            (held_from, released_at) = (index, wall);
        }
        let edge = &mut edges[index];
        let saves = edge.hold(fleet.tick(index, wall, timer));
        edge.store(fleet.vehicles_mut()[index].core(), saves);
    }
    edges[held_from..].iter_mut().for_each(Edge::release);
}
