//! Everything the user can ask of the designer. Keys become actions through [`crate::tui::keymap`];
//! [`crate::tui::update::update`] carries them out.

/// An arrow direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    Up,
    Down,
    Left,
    Right,
}

/// One user intent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Move the selection in the focused panel (matrix cell, slider, setting) or change a slider.
    Move(Direction),
    /// A large slider step (±16/255, ±1 weight) up or down.
    BigStep {
        up: bool,
    },
    /// A list: jump to its first (`last: false`) or last entry.
    ListEnd {
        last: bool,
    },
    FocusNext,
    FocusPrev,
    /// Matrix: edit the cell's sliders; settings: toggle or edit the field.
    Activate,
    /// Close the popup, or go back to the matrix.
    Back,
    HexEntry,
    EditWeight,
    ToggleDesign,
    ToggleUse,
    AssignFree,
    FreeBounds,
    FitColour,
    FitAll,
    Planck,
    NormaliseLuminance,
    NormaliseL2,
    Scale,
    AddLight,
    AddReflectance,
    Remove,
    /// Rename the selected light or reflectance (on a cell: its light, reflectance or free-colour group).
    Rename,
    ToggleBounds,
    ToggleFitInSubspace,
    Undo,
    Redo,
    Save,
    /// Save the palette to a path typed in a prompt; that file becomes the palette file.
    SaveAs,
    /// Read the palette file again (another program changed it), dropping unsaved changes (undo keeps them).
    Reload,
    Help,
    /// The legend of the marks.
    Legend,
    /// Search the palette and jump (`/`), or run a command by name (`:`).
    Find {
        commands: bool,
    },
    /// List the solver's diagnostics.
    Diagnostics,
    /// Move along the light dial of the scene preview.
    Dial {
        forward: bool,
    },
    /// Show the scene preview or the spectra in the bottom panel.
    TogglePreview,
    /// Show or hide the selected cell's metamer mismatch region.
    Feasibility,
    /// Give the keys to the light dial beside the preview.
    DialKeys,
    /// Dial keys: move the slider (or the selected vertex) by (dx, dy) steps, small or large.
    DialSlide {
        dx: i8,
        dy: i8,
        big: bool,
    },
    /// Dial keys: switch light N (1-based) on or off.
    DialToggle(u8),
    /// Dial keys: select the next (or previous) of slider, vertex 1, vertex 2, …
    DialSelect {
        forward: bool,
    },
    /// Dial keys: the selected light's intensity up or down.
    DialIntensity {
        up: bool,
    },
    /// Dial keys: add the dial as it stands as a keyframe.
    DialKeyframe,
    /// Dial keys: list the keyframes (show or delete one).
    DialKeyframes,
    /// Dial keys: write the keyframes into the scene file.
    DialSaveScene,
    /// Leave the dial keys.
    DialLeave,
    /// Dial keys: add a target for the selected reflectance at the slider ([`crate::tui::dial_list`]).
    DialAddMixture,
    /// The list of the criteria along the dial (`[[mixtures]]`, `[[paths]]`).
    DialList,
    /// The list: the selected path's design samples.
    DialSamples,
    /// The list: the selected path's tolerance.
    DialTolerance,
    /// The relit preview over the whole terminal, or back to the panels.
    PreviewFull,
    Quit,
    // Inside popups.
    /// Edit the prompt's line: type a character, move the cursor, delete (the line editing is tui-input's).
    Edit(tui_input::InputRequest),
    /// Complete the path typed in a path prompt (Tab).
    Complete,
    /// Accept the prompt or the highlighted list entry.
    Submit,
    /// Choose the light / the reflectance of the selected cell.
    ChooseLight,
    ChooseReflectance,
    /// Choose the free-colour group of the selected cell (rename).
    ChooseGroup,
    /// Quit without saving.
    Discard,
    /// Save, then quit.
    SaveAndQuit,
    /// Take the recovery copy's palette as the one being edited.
    Restore,
}
