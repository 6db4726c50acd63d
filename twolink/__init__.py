"""twolink: a two-link arm in MuJoCo with CTC and FCM fuzzy controllers."""
