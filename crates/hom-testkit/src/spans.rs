//! A `tracing` subscriber that records each span entered as `name:stage`
//! (its `stage` field): what the span tests of hom's `tracing` feature and
//! hom-bevy's `trace` feature compare.

use std::sync::{Arc, Mutex};
use tracing::field::{Field, Visit};
use tracing::span::{Attributes, Id, Record};
use tracing::{Event, Metadata, Subscriber};

/// Records every span entered, in order; clones share the record.
#[derive(Clone, Default)]
pub struct SpanRecorder {
    spans: Arc<Mutex<Vec<String>>>,
    entered: Arc<Mutex<Vec<String>>>,
}

impl SpanRecorder {
    /// The spans entered so far, each as `name:stage`.
    pub fn entered(&self) -> Vec<String> {
        self.entered.lock().expect("not poisoned").clone()
    }
}

/// Reads a span's `stage` field.
struct StageField(String);

impl Visit for StageField {
    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "stage" {
            self.0 = value.to_string();
        }
    }
    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "stage" {
            self.0 = format!("{value:?}").trim_matches('"').to_string();
        }
    }
}

impl Subscriber for SpanRecorder {
    fn enabled(&self, _: &Metadata<'_>) -> bool {
        true
    }
    fn new_span(&self, span: &Attributes<'_>) -> Id {
        let mut stage = StageField(String::new());
        span.record(&mut stage);
        let mut spans = self.spans.lock().expect("not poisoned");
        spans.push(format!("{}:{}", span.metadata().name(), stage.0));
        Id::from_u64(spans.len() as u64)
    }
    fn record(&self, _: &Id, _: &Record<'_>) {}
    fn record_follows_from(&self, _: &Id, _: &Id) {}
    fn event(&self, _: &Event<'_>) {}
    fn enter(&self, id: &Id) {
        let span = self.spans.lock().expect("not poisoned")[id.into_u64() as usize - 1].clone();
        self.entered.lock().expect("not poisoned").push(span);
    }
    fn exit(&self, _: &Id) {}
}
