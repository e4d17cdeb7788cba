//! The `preview` command: the render flags as the first settings of a live
//! preview served by `twinray-preview`.

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::atomic::Ordering;

use anyhow::{Context, Result};

use twinray_args::RenderArgs;

#[derive(clap::Args)]
pub struct PreviewArgs {
    #[command(flatten)]
    pub render: RenderArgs,
    /// Port to listen on (default: a free one; the URL is printed).
    #[arg(long)]
    pub port: Option<u16>,
    /// Address to listen on instead of 127.0.0.1. The preview has no
    /// authentication: anyone who reaches the address can render with it and
    /// download the renders.
    #[arg(long, value_name = "ADDRESS")]
    pub bind: Option<IpAddr>,
    /// Open the page in the desktop's browser.
    #[arg(long)]
    pub open: bool,
    /// Width of the preview image per view, in pixels (smaller images come
    /// back faster; --size sets the full-size render).
    #[arg(long, value_name = "PIXELS", default_value_t = twinray_preview::DEFAULT_PREVIEW_WIDTH)]
    pub preview_width: u32,
}

pub fn run(args: &PreviewArgs) -> Result<()> {
    let spec = crate::render_spec(&args.render)?;
    let address = args.bind.unwrap_or(IpAddr::V4(Ipv4Addr::LOCALHOST));
    if !address.is_loopback() {
        eprintln!(
            "twinray: warning: --bind {address}: the preview listens beyond this machine, \
             and anyone who reaches it can render and download (it has no authentication)"
        );
    }
    let preview = twinray_preview::Preview::new(spec, args.preview_width)?;
    crate::print_messages(&preview.load_messages(), &args.render);
    if let Some(error) = preview.load_error() {
        // The page shows it too; the server runs so that the file can be
        // fixed and reloaded from the page.
        eprintln!("twinray: {error}");
    }
    // Ctrl-C raises the token: the server stops, the temporary files go.
    crate::RENDERING.store(true, Ordering::Relaxed);
    let open = args.open;
    let result = twinray_preview::run(
        preview,
        SocketAddr::new(address, args.port.unwrap_or(0)),
        |bound| {
            let url = format!("http://{bound}/");
            println!("twinray preview: {url}  (Ctrl-C stops)");
            if open {
                if let Err(e) = twinray_preview::open_in_browser(&url) {
                    eprintln!("twinray: warning: cannot open a browser ({e}): open {url} yourself");
                }
            }
        },
        crate::cancel_token().clone(),
    );
    crate::RENDERING.store(false, Ordering::Relaxed);
    result.with_context(|| format!("cannot serve on {address}"))
}
