//! `twinray render --frames A..B`: an animation, frame after frame, with a
//! progress bar over the frames and each frame's messages.

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::atomic::Ordering;

use anyhow::Result;

use twinray::animation::{Animation, FrameProgress, FrameReport};
use twinray::job::{JobSpec, Level};

use crate::{cancel_token, interrupted, print_messages, progress_bar, RENDERING};
use twinray_args::RenderArgs;

/// Bar positions per frame: the frame's own progress in thousandths.
const STEPS: u64 = 1000;

pub fn run(spec: JobSpec, args: &RenderArgs) -> Result<Vec<PathBuf>> {
    let animation = Animation::check(spec)?;
    print_messages(animation.messages(), args);
    let loaded = animation.load()?;
    print_messages(&loaded.messages, args);
    let count = u64::from(animation.frames().count());
    let bar = progress_bar(
        args,
        "{spinner} {msg} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
    );
    bar.set_length(count * STEPS);
    let progress = |p: FrameProgress| {
        bar.set_message(format!("frame {} ({}/{})", p.frame, p.index + 1, p.count));
        bar.set_position(u64::from(p.index) * STEPS + p.done * STEPS / p.total.max(1));
    };
    // Each warning and note once for the shot, not once a frame.
    let mut told: HashSet<String> = HashSet::new();
    let mut on_frame = |r: FrameReport| {
        let fresh: Vec<_> = r
            .messages
            .into_iter()
            .filter(|m| m.level == Level::Info || told.insert(m.text.clone()))
            .collect();
        bar.suspend(|| {
            print_messages(&fresh, args);
            if args.output.quiet {
                return;
            }
            if r.skipped {
                eprintln!("frame {}: done already, skipped", r.frame);
            } else {
                // As each frame is written, with its number: a driver
                // (twinray-ray) follows these lines for its progress.
                for path in &r.written {
                    eprintln!("frame {}: wrote {}", r.frame, path.display());
                }
            }
        });
    };
    RENDERING.store(true, Ordering::Relaxed);
    let result = animation.run(&loaded, &progress, &mut on_frame, cancel_token());
    RENDERING.store(false, Ordering::Relaxed);
    bar.finish_and_clear();
    if let Err(twinray::Error::Cancelled) = result {
        interrupted();
    }
    let (written, messages) = result?;
    print_messages(&messages, args);
    // The frames' files were listed as they were written; a video is left.
    Ok(written
        .into_iter()
        .filter(|p| twinray::video::Container::of(p).is_some())
        .collect())
}
