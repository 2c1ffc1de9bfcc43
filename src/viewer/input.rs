//! Keyboard input as egui should see it at any frame rate. egui moves the focus on a
//! Tab at the start of a frame, and the widget that receives it reads every text event
//! of that frame, typed before the Tab or not: typing "256", Tab at 4 frames a second
//! put the "6" into the next field ("Height 25", "Bins 2566"). So a frame's input is
//! cut at a Tab: what was typed before it stays in this frame, the Tab starts the next
//! one and ends it, and what follows goes to the frame after.

use eframe::egui::{Event, Key};

/// Whether `e` is a press of Tab (either direction).
fn is_tab(e: &Event) -> bool {
    matches!(
        e,
        Event::Key {
            key: Key::Tab,
            pressed: true,
            ..
        }
    )
}

/// Whether `e` is typing (text, a paste, or a key press other than Tab).
fn is_typing(e: &Event) -> bool {
    matches!(
        e,
        Event::Text(_) | Event::Paste(_) | Event::Key { pressed: true, .. }
    ) && !is_tab(e)
}

/// Cut `events` (this frame's, in order) so that a Tab press never shares a frame with
/// typing: the events from the first Tab on that follows typing, or those after a Tab
/// that comes first, are taken out and returned, for the next frame.
pub(super) fn split_at_tab(events: &mut Vec<Event>) -> Vec<Event> {
    let Some(tab) = events.iter().position(is_tab) else {
        return Vec::new();
    };
    let cut = if events[..tab].iter().any(is_typing) {
        tab
    } else {
        tab + 1
    };
    if events[cut..].iter().any(|e| is_tab(e) || is_typing(e)) {
        events.split_off(cut)
    } else {
        Vec::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use eframe::egui::Modifiers;

    fn key(k: Key) -> Event {
        Event::Key {
            key: k,
            physical_key: None,
            pressed: true,
            repeat: false,
            modifiers: Modifiers::NONE,
        }
    }

    fn text(s: &str) -> Event {
        Event::Text(s.into())
    }

    #[test]
    fn a_tab_never_shares_a_frame_with_typing() {
        // "56", Tab, "51" in one frame: "56" now, then Tab alone, then "51".
        let mut frame = vec![text("5"), text("6"), key(Key::Tab), text("5"), text("1")];
        let next = {
            let mut rest = split_at_tab(&mut frame);
            assert_eq!(frame, vec![text("5"), text("6")]);
            let after = split_at_tab(&mut rest);
            assert_eq!(rest, vec![key(Key::Tab)]);
            after
        };
        assert_eq!(next, vec![text("5"), text("1")]);
        // A Tab alone, or with nothing typed after it, stays.
        let mut frame = vec![key(Key::Tab)];
        assert!(split_at_tab(&mut frame).is_empty());
        let mut frame = vec![
            text("7"),
            Event::PointerGone,
            Event::Key {
                key: Key::Tab,
                physical_key: None,
                pressed: false,
                repeat: false,
                modifiers: Modifiers::NONE,
            },
        ];
        assert!(split_at_tab(&mut frame).is_empty());
        // Two Tabs: one a frame.
        let mut frame = vec![key(Key::Tab), key(Key::Tab)];
        assert_eq!(split_at_tab(&mut frame), vec![key(Key::Tab)]);
        assert_eq!(frame, vec![key(Key::Tab)]);
    }
}
