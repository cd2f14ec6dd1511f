//! Files next to the page and dropped on it (split from `lib.rs` by job): the meshes,
//! MTL libraries and texture images fetched from `models/`, the files a person drops, and
//! the report POSTed to `report=`.

use std::cell::RefCell;
use std::rc::Rc;

use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;

use super::{document, fail, show_status, App};

/// A file next to the page, read synchronously (the `models/` folder; `None` when absent).
pub fn fetch_text(url: &str) -> Option<String> {
    let xhr = web_sys::XmlHttpRequest::new().ok()?;
    xhr.open_with_async("GET", url, false).ok()?;
    xhr.send().ok()?;
    (xhr.status().ok()? == 200).then(|| xhr.response_text().ok().flatten())?
}

/// A binary file next to the page (a texture image), read synchronously. A synchronous
/// request cannot ask for an `arraybuffer`; the user-defined charset hands each byte over
/// as one character (0x00-0x7f as is, 0x80-0xff as U+F780-U+F7FF), its low byte the byte.
pub fn fetch_bytes(url: &str) -> Option<Vec<u8>> {
    let xhr = web_sys::XmlHttpRequest::new().ok()?;
    xhr.open_with_async("GET", url, false).ok()?;
    xhr.override_mime_type("text/plain; charset=x-user-defined")
        .ok()?;
    xhr.send().ok()?;
    let text = (xhr.status().ok()? == 200).then(|| xhr.response_text().ok().flatten())??;
    Some(text.chars().map(|c| (c as u32 & 0xff) as u8).collect())
}

/// POSTs `body` to `url` with one header (fire and forget).
pub fn post(url: &str, header: &str, value: &str, body: &[u8]) {
    let Ok(xhr) = web_sys::XmlHttpRequest::new() else {
        return;
    };
    if xhr.open("POST", url).is_err() {
        return;
    }
    let _ = xhr.set_request_header(header, value);
    let _ = xhr.send_with_opt_u8_array(Some(body));
}
/// A dropped `.toml` replaces the scene; dropped `.obj`/`.mtl` files are its meshes and
/// `.png`/`.jpg`/`.tga` files their textures (by file name). Files are read through
/// `Blob.text()` (images: `Blob.arrayBuffer()`) promises, then the scene reloads.
pub fn install_drop(app: &Rc<RefCell<App>>) -> Result<(), JsValue> {
    let body = document().body().ok_or("no body")?;
    let over = Closure::<dyn FnMut(web_sys::DragEvent)>::new(|e: web_sys::DragEvent| {
        e.prevent_default();
    });
    body.add_event_listener_with_callback("dragover", over.as_ref().unchecked_ref())?;
    over.forget();
    let a = app.clone();
    let drop = Closure::<dyn FnMut(web_sys::DragEvent)>::new(move |e: web_sys::DragEvent| {
        e.prevent_default();
        let Some(files) = e.data_transfer().and_then(|d| d.files()) else {
            return;
        };
        let pending = Rc::new(RefCell::new(files.length()));
        for k in 0..files.length() {
            let Some(file) = files.get(k) else { continue };
            let name = file.name();
            let (a, pending) = (a.clone(), pending.clone());
            let lower = name.to_ascii_lowercase();
            let image = [".png", ".jpg", ".jpeg", ".tga"]
                .iter()
                .any(|e| lower.ends_with(e));
            let then = Closure::<dyn FnMut(JsValue)>::new(move |got: JsValue| {
                let mut app = a.borrow_mut();
                let text = got.as_string().unwrap_or_default();
                if image {
                    let bytes = js_sys::Uint8Array::new(&got).to_vec();
                    app.images.insert(name.clone(), bytes);
                } else if name.ends_with(".toml") {
                    app.scene_name = name.trim_end_matches(".toml").to_string();
                    app.toml = text;
                } else {
                    app.texts.insert(name.clone(), text);
                }
                *pending.borrow_mut() -= 1;
                if *pending.borrow() == 0 {
                    app.reported = true;
                    if let Err(e) = app.load() {
                        fail(&mut app, &e);
                    } else {
                        show_status(&app);
                    }
                }
            });
            let _ = if image {
                file.array_buffer().then(&then)
            } else {
                file.text().then(&then)
            };
            then.forget();
        }
    });
    body.add_event_listener_with_callback("drop", drop.as_ref().unchecked_ref())?;
    drop.forget();
    Ok(())
}
