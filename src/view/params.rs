//! Parameter widgets generated from the node declarations (`wedge_graph::ParamDecl`): a range
//! becomes a slider (logarithmic where it spans decades), an unbounded one a drag value, a choice a
//! combo box, a bool a checkbox. No node has UI code of its own: a node added to a pipeline gets its
//! widgets from what it declares.

use wedge_graph::{ParamDecl, ParamKind, ParamValue};

/// The widget a declaration gets.
#[derive(Clone, Debug, PartialEq)]
pub enum Widget {
    Float {
        lo: f64,
        hi: f64,
        log: bool,
        slider: bool,
    },
    Int {
        lo: i64,
        hi: i64,
        slider: bool,
    },
    Check,
    Combo(&'static [&'static str]),
    /// Three numbers; a colour within [0, 1] gets egui's colour picker (linear RGB), any other
    /// three drag values.
    Vec3 {
        lo: f64,
        hi: f64,
        picker: bool,
    },
    /// File parameters are edited in the RON file (hot reload picks the edit up).
    None,
}

/// Widest range a slider covers; wider ranges get a drag value (a pixel would be too coarse).
const SLIDER_SPAN: f64 = 1e6;

/// The widget for `decl`.
pub fn widget_for(decl: &ParamDecl) -> Widget {
    match decl.kind {
        ParamKind::Float { min, max, min_exclusive, .. } => {
            // An exclusive 0 (`mu > 0`) starts a logarithmic slider just above it.
            let lo = if min_exclusive { next_up(min, max) } else { min };
            let slider = lo.is_finite() && max.is_finite() && max - lo <= SLIDER_SPAN;
            let log = slider && lo > 0.0 && max / lo >= 100.0;
            Widget::Float { lo, hi: max, log, slider }
        }
        ParamKind::Int { min, max, .. } => Widget::Int { lo: min, hi: max, slider: (max - min) as f64 <= 4096.0 },
        ParamKind::Bool { .. } => Widget::Check,
        ParamKind::Choice { options, .. } => Widget::Combo(options),
        ParamKind::Path { .. } => Widget::None,
        ParamKind::Vec3 { min, max, colour, .. } => {
            Widget::Vec3 { lo: min, hi: max, picker: colour && min >= 0.0 && max <= 1.0 }
        }
    }
}

/// A value just above an exclusive minimum, small against the range (`min < x`).
fn next_up(min: f64, max: f64) -> f64 {
    if min == 0.0 && max.is_finite() && max > 0.0 {
        (max * 1e-4).min(0.01)
    } else {
        min + (max - min).abs().min(1.0) * 1e-3
    }
}

/// The value widget `id` shows: the one being dragged, else `model` (the session's). A drag keeps its
/// value in egui's memory because the session changes only when the drag ends, and a drag value
/// reset to the session's each frame would never move.
pub(super) fn shown<T: Clone + Send + Sync + 'static>(ui: &egui::Ui, id: &str, model: T) -> T {
    ui.data(|d| d.get_temp(drag_key(id))).unwrap_or(model)
}

/// Where a dragged value of widget `id` is kept (one key per widget, whatever panel draws it).
fn drag_key(id: &str) -> egui::Id {
    egui::Id::unique(("wedge view drag", id))
}

/// After widget `id` drew `value`: `Some(value)` when the edit is finished — a click or a typed value
/// at once, a drag when released (a rebuild per dragged pixel would queue dozens of sessions).
pub(super) fn commit<T: Clone + Send + Sync + 'static>(
    ui: &egui::Ui,
    id: &str,
    r: &egui::Response,
    value: T,
) -> Option<T> {
    let key = drag_key(id);
    if r.dragged() {
        ui.data_mut(|d| d.insert_temp(key, value));
        return None;
    }
    let dragging = ui.data_mut(|d| {
        let held = d.get_temp::<T>(key).is_some();
        d.remove::<T>(key);
        held
    });
    (dragging || r.drag_stopped() || r.changed()).then_some(value)
}

/// One parameter's widget; `Some(new value)` when the user committed a change.
pub fn param_ui(ui: &mut egui::Ui, id: &str, decl: &ParamDecl, value: Option<&ParamValue>) -> Option<ParamValue> {
    let now = value.cloned().unwrap_or_else(|| decl.default_value());
    let changed = match (widget_for(decl), now) {
        (Widget::Float { lo, hi, log, slider }, v) => {
            let mut x = shown(ui, id, v.as_f64().unwrap_or(lo));
            let r = if slider {
                ui.add(egui::Slider::new(&mut x, lo..=hi).logarithmic(log).text(decl.name))
            } else {
                ui.horizontal(|ui| {
                    ui.add(egui::DragValue::new(&mut x).range(lo..=hi).speed(0.01)) | ui.label(decl.name)
                })
                .inner
            };
            commit(ui, id, &r, x).map(ParamValue::Float)
        }
        (Widget::Int { lo, hi, slider }, ParamValue::Int(i)) => {
            let mut i = shown(ui, id, i);
            let r = if slider {
                ui.add(egui::Slider::new(&mut i, lo..=hi).text(decl.name))
            } else {
                ui.horizontal(|ui| ui.add(egui::DragValue::new(&mut i).range(lo..=hi)) | ui.label(decl.name)).inner
            };
            commit(ui, id, &r, i).map(ParamValue::Int)
        }
        (Widget::Check, ParamValue::Bool(mut b)) => {
            ui.checkbox(&mut b, decl.name).changed().then_some(ParamValue::Bool(b))
        }
        (Widget::Combo(options), ParamValue::Str(s)) => {
            let mut chosen = s.clone();
            egui::ComboBox::from_id_salt(id).selected_text(format!("{}: {s}", decl.name)).show_ui(ui, |ui| {
                for o in options {
                    ui.selectable_value(&mut chosen, o.to_string(), *o);
                }
            });
            (chosen != s).then_some(ParamValue::Str(chosen))
        }
        (Widget::Vec3 { lo, hi, picker }, ParamValue::Vec3(v)) => vec3_ui(ui, id, decl.name, v, (lo, hi), picker),
        (_, v) => {
            ui.label(format!("{} = {v:?}", decl.name));
            None
        }
    };
    changed
}

/// A colour picker (linear RGB, a value within [0, 1]) or three drag values in `lo..=hi`.
fn vec3_ui(
    ui: &mut egui::Ui,
    id: &str,
    name: &str,
    v: [f64; 3],
    (lo, hi): (f64, f64),
    picker: bool,
) -> Option<ParamValue> {
    let mut x = shown(ui, id, v);
    let r = ui
        .horizontal(|ui| {
            let r = if picker {
                let mut rgb = x.map(|c| c as f32);
                let r = ui.color_edit_button_rgb(&mut rgb);
                x = rgb.map(f64::from);
                r
            } else {
                let [a, b, c] = &mut x;
                ui.add(egui::DragValue::new(a).range(lo..=hi).speed(0.01))
                    | ui.add(egui::DragValue::new(b).range(lo..=hi).speed(0.01))
                    | ui.add(egui::DragValue::new(c).range(lo..=hi).speed(0.01))
            };
            r | ui.label(name)
        })
        .inner;
    commit(ui, id, &r, x).map(ParamValue::Vec3)
}

/// Every node's widgets; `Some((node, param, value))` for the change the user committed this frame.
pub fn pipeline_ui(
    ui: &mut egui::Ui,
    pipeline: &wedge_graph::ValidatedPipeline,
) -> Option<(String, String, ParamValue)> {
    let mut change = None;
    for node in &pipeline.nodes {
        let decls: Vec<ParamDecl> = node.kind.params().into_iter().filter(|d| widget_for(d) != Widget::None).collect();
        if decls.is_empty() {
            continue;
        }
        egui::CollapsingHeader::new(format!("{} ({})", node.name, node.kind.kind())).default_open(true).show(
            ui,
            |ui| {
                for d in &decls {
                    let id = format!("{}.{}", node.name, d.name);
                    let r = param_ui(ui, &id, d, node.params.get(d.name));
                    if let Some(v) = r {
                        change = Some((node.name.clone(), d.name.to_string(), v));
                    }
                }
            },
        );
    }
    change
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every parameter of every shipped node gets a widget (files excepted), with a usable range.
    #[test]
    fn every_declared_parameter_gets_a_widget() {
        let (nodes, _) = wedge_effects::builtin();
        let mut count = 0;
        for name in nodes.names() {
            let kind = nodes.get(name).expect("registered");
            for d in kind.params() {
                match widget_for(&d) {
                    Widget::Float { lo, hi, .. } => {
                        assert!(lo <= hi, "{}.{}: {lo}..{hi}", kind.kind(), d.name)
                    }
                    Widget::Int { lo, hi, .. } => assert!(lo <= hi, "{}.{}", kind.kind(), d.name),
                    Widget::Combo(o) => assert!(!o.is_empty()),
                    Widget::Check => {}
                    Widget::Vec3 { lo, hi, .. } => assert!(lo <= hi, "{}.{}", kind.kind(), d.name),
                    Widget::None => assert!(matches!(d.kind, ParamKind::Path { .. })),
                }
                count += 1;
            }
        }
        assert!(count > 20, "{count} parameters");
    }

    /// A colour within [0, 1] gets the colour picker; a radiance colour (unbounded) or a vector,
    /// three numbers.
    #[test]
    fn a_colour_gets_a_picker_and_a_vector_three_numbers() {
        let albedo = ParamDecl::colour("albedo", [0.5; 3], 1.0, "k_d");
        assert_eq!(widget_for(&albedo), Widget::Vec3 { lo: 0.0, hi: 1.0, picker: true });
        let radiance = ParamDecl::colour("colour", [0.5; 3], 1e6, "fog radiance");
        assert_eq!(widget_for(&radiance), Widget::Vec3 { lo: 0.0, hi: 1e6, picker: false });
        let v = ParamDecl::vec3("offset", [0.0; 3], -10.0, 10.0, "metres");
        assert_eq!(widget_for(&v), Widget::Vec3 { lo: -10.0, hi: 10.0, picker: false });
    }

    #[test]
    fn mu_gets_a_logarithmic_slider_above_zero() {
        let d = ParamDecl::positive("mu", 2.0, 100.0, "bandwidth scale");
        let Widget::Float { lo, hi, log, slider } = widget_for(&d) else { panic!("float") };
        assert!(lo > 0.0 && hi == 100.0 && log && slider, "{lo} {hi} {log} {slider}");
    }
}
