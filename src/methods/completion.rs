//! Shape completion and partial registration (FBT Figs. 6–8): one
//! `CompletionProblem`, solved by FBT, Der et al. or Amberg et al.
