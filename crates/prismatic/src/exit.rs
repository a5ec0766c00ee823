//! The exit status of `prismatic` and the message on stderr, both decided from an error's chain of causes.
//!
//! The status comes from the types of the causes (downcast through anyhow's chain, outermost first), never from the
//! message's words; README.md ("Exit status") lists the codes. Status 2, a command line that cannot be parsed, is
//! clap's own: it exits before any command runs.

use anyhow::Error;

use crate::render_cmd::Interrupted;

/// Anything else that failed: an option value refused, a checkpoint or part that does not fit, an image format.
pub const FAILURE: u8 = 1;
/// The scene is wrong: an error in a scene file or in a file it references, reported as `file:line:column: error:`.
pub const SCENE: u8 = 3;
/// A file named on the command line (or by a checkpoint or part) cannot be read, or an output cannot be written.
pub const IO: u8 = 4;

/// The exit status for `e`: that of the first cause whose type says what failed (an interrupted render keeps its
/// 128 + signal number), [`FAILURE`] if none does.
pub fn code(e: &Error) -> u8 {
    for cause in e.chain() {
        if let Some(stopped) = cause.downcast_ref::<Interrupted>() {
            return stopped.exit_code;
        }
        if cause.is::<pbrt::ParseError>() || cause.is::<scene::SceneError>() || cause.is::<gltf_import::GltfError>() {
            return SCENE;
        }
        if let Some(r) = cause.downcast_ref::<render::RenderError>() {
            use render::RenderError::*;
            return match r {
                Scene(_) | ReferencedFile { .. } => SCENE,
                Io { .. } => IO,
                InvalidData { .. } | Film(_) | StateMismatch(_) => FAILURE,
            };
        }
        // Also below film's `ImageError::Io`, which keeps the operating system's error as its cause.
        if cause.is::<std::io::Error>() {
            return IO;
        }
    }
    FAILURE
}

/// `e` as one line: each cause after its context, as anyhow's `{:#}` writes it, except causes whose text the message
/// already holds (errors such as film's `ImageError::Io` write their cause into their own message).
pub fn message(e: &Error) -> String {
    let mut msg = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if msg.contains(&text) {
            continue;
        }
        if !msg.is_empty() {
            msg.push_str(": ");
        }
        msg.push_str(&text);
    }
    msg
}

/// An error that the file system is not as needed (a missing directory, a missing file), typed as I/O so that the
/// exit status says so; `message` says which file and what is wrong.
pub fn io_error(kind: std::io::ErrorKind, message: String) -> Error {
    Error::new(std::io::Error::new(kind, message))
}

#[cfg(test)]
mod tests {
    use std::path::Path;
    use std::sync::Arc;

    use anyhow::Context;

    use super::*;

    #[test]
    fn codes_follow_the_types_of_the_causes() {
        let loc = scene::Loc::new(Arc::from(Path::new("s.pbrt")), 2, 3);
        let scene_error = scene::SceneError::at(loc.clone(), "bad");
        assert_eq!(code(&Error::new(scene_error.clone())), SCENE);
        assert_eq!(code(&Error::new(pbrt::ParseError::new(loc.clone(), "bad"))), SCENE);
        assert_eq!(code(&Error::new(render::RenderError::from(scene_error))), SCENE);
        let file = render::RenderError::ReferencedFile { loc, path: "t.png".into(), message: "gone".into() };
        assert_eq!(code(&Error::new(file)), SCENE);
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "gone");
        assert_eq!(code(&Error::new(io).context("cannot read x")), IO);
        assert_eq!(code(&Error::new(render::RenderError::StateMismatch("no".into())).context("checkpoint c")), FAILURE);
        assert_eq!(code(&anyhow::anyhow!("--spp must be between 1 and 16777216, got 0")), FAILURE);
        let stopped = Interrupted { message: "interrupted".into(), exit_code: 143 };
        assert_eq!(code(&Error::new(stopped)), 143);
        let written: Result<(), _> = Err(film::ImageError::Io {
            path: "out.exr".into(),
            source: std::io::Error::new(std::io::ErrorKind::PermissionDenied, "denied"),
        });
        let e = written.context("cannot write out.exr").unwrap_err();
        assert_eq!(code(&e), IO);
        // The operating system's error is in ImageError's own message: written once.
        assert_eq!(message(&e), "cannot write out.exr: out.exr: denied");
    }
}
