//! When a running furrow stops.

/// Completes at SIGINT or SIGTERM (never, if the handlers cannot be
/// installed: the process then ends by the default action). Await it on the
/// edge runtime.
pub async fn signal() {
    use tokio::signal::unix::{SignalKind, signal};
    let Ok(mut term) = signal(SignalKind::terminate()) else {
        tracing::error!("SIGTERM handler not installed");
        return std::future::pending().await;
    };
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        _ = term.recv() => {}
    }
}
