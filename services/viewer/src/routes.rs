//! What each request gets: the page, the next picture (long-polled), a PNG snapshot,
//! the panels' state as JSON, the push stream of events, and the health check. Every answer is made from the
//! request's method and target alone; bad input is a 4xx, never a panic.

use crate::pictures::Shared;
use crate::push;
use http_body_util::{Either, Full};
use hyper::body::Bytes;
use hyper::{Method, Response, StatusCode};
use std::sync::Arc;

const PAGE: &str = include_str!("page.html");
/// The path the health check asks for ([`crate::health`]).
pub const HEALTH_PATH: &str = "/healthz";
/// Longest request target served: the page's own are under 40 bytes.
pub const MAX_TARGET: usize = 2048;

/// A whole answer, or the push stream's.
pub(crate) type Reply = Response<Either<Full<Bytes>, push::Stream>>;

fn reply(status: StatusCode, content_type: &str, body: impl Into<Bytes>) -> Reply {
    headed(status, content_type, Either::Left(Full::new(body.into())))
}

fn headed(
    status: StatusCode,
    content_type: &str,
    body: Either<Full<Bytes>, push::Stream>,
) -> Reply {
    let mut r = Response::new(body);
    *r.status_mut() = status;
    let h = r.headers_mut();
    h.insert(
        hyper::header::CONTENT_TYPE,
        hyper::header::HeaderValue::from_str(content_type).expect("ASCII content type"),
    );
    // Every answer is live: nothing may be served from a cache.
    h.insert(
        hyper::header::CACHE_CONTROL,
        hyper::header::HeaderValue::from_static("no-store"),
    );
    r
}

pub(crate) fn text(status: StatusCode, body: &str) -> Reply {
    reply(status, "text/plain; charset=utf-8", body.to_owned())
}

/// The value of `key` in a query string `a=1&b=2`.
pub(crate) fn query_value<'a>(query: &'a str, key: &str) -> Option<&'a str> {
    query
        .split('&')
        .filter_map(|kv| kv.split_once('='))
        .find(|(k, _)| *k == key)
        .map(|(_, v)| v)
}

/// Runs picture work (drawing, encoding, pacing) on the runtime's few blocking threads.
async fn blocking<T: Send + 'static>(
    shared: &Arc<Shared>,
    work: impl FnOnce(&Shared) -> Result<Option<T>, String> + Send + 'static,
) -> Result<Option<T>, String> {
    let shared = shared.clone();
    tokio::task::spawn_blocking(move || work(&shared))
        .await
        .map_err(|e| format!("the picture task failed: {e}"))?
}

/// The answer to one request.
pub(crate) async fn route(shared: &Arc<Shared>, method: &Method, target: &str) -> Reply {
    if *method != Method::GET && *method != Method::HEAD {
        return text(StatusCode::METHOD_NOT_ALLOWED, "only GET");
    }
    if target.len() > MAX_TARGET {
        return text(StatusCode::URI_TOO_LONG, "request target too long");
    }
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    match path {
        "/" | "/index.html" => reply(StatusCode::OK, "text/html; charset=utf-8", PAGE),
        HEALTH_PATH => text(StatusCode::OK, "ok"),
        "/events" => match push::Wants::parse(query) {
            Ok(wants) => headed(
                StatusCode::OK,
                "text/event-stream",
                Either::Right(push::open(shared.push(), wants)),
            ),
            Err(e) => text(StatusCode::BAD_REQUEST, &e),
        },
        "/state.json" => reply(
            StatusCode::OK,
            "application/json",
            shared.state().to_string(),
        ),
        "/frame.jpg" => {
            let after = match query_value(query, "after").map(str::parse::<u64>) {
                None => 0,
                Some(Ok(n)) => n,
                Some(Err(_)) => {
                    return text(StatusCode::BAD_REQUEST, "after must be a picture number")
                }
            };
            if !shared.wait_for_frame_after(after).await {
                return text(StatusCode::NO_CONTENT, "");
            }
            match blocking(shared, move |s| s.newest_jpeg(after)).await {
                Ok(Some(e)) => {
                    let mut r = reply(StatusCode::OK, "image/jpeg", e.jpeg.to_vec());
                    r.headers_mut()
                        .insert("X-Picture", hyper::header::HeaderValue::from(e.id));
                    r
                }
                Ok(None) => text(StatusCode::NO_CONTENT, ""),
                Err(e) => text(
                    StatusCode::INTERNAL_SERVER_ERROR,
                    &format!("cannot encode the picture: {e}"),
                ),
            }
        }
        "/snapshot.png" => match blocking(shared, Shared::snapshot_png).await {
            Ok(Some(png)) => reply(StatusCode::OK, "image/png", png),
            Ok(None) => text(
                StatusCode::SERVICE_UNAVAILABLE,
                "no depth frame yet: is capture running?",
            ),
            Err(e) => text(
                StatusCode::INTERNAL_SERVER_ERROR,
                &format!("cannot encode the picture: {e}"),
            ),
        },
        _ => text(StatusCode::NOT_FOUND, "not found"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pictures::tests::shared_with_frames;

    fn status(shared: &Arc<Shared>, method: Method, target: &str) -> u16 {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap()
            .block_on(route(shared, &method, target))
            .status()
            .as_u16()
    }

    #[test]
    fn routes_answer_and_bad_input_is_refused_not_a_panic() {
        let shared = Arc::new(shared_with_frames(3, 1000.0));
        let get = |target: &str| status(&shared, Method::GET, target);
        assert_eq!(get("/"), 200);
        assert_eq!(get(HEALTH_PATH), 200);
        assert_eq!(get("/state.json"), 200);
        assert_eq!(get("/nope"), 404);
        assert_eq!(get("/frame.jpg?after=x"), 400);
        assert_eq!(get("/events?skeletons=x"), 400);
        assert_eq!(get("/events?skeletons=10"), 200);
        assert_eq!(get(&format!("/{}", "a".repeat(MAX_TARGET))), 414);
        assert_eq!(status(&shared, Method::POST, "/"), 405);
        assert_eq!(get("/frame.jpg?after=0"), 200);
        assert_eq!(get("/snapshot.png"), 200);
        let empty = Arc::new(shared_with_frames(0, 1000.0));
        assert_eq!(status(&empty, Method::GET, "/snapshot.png"), 503);
    }
}
